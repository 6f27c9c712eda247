# register: video-to-CT registration (`mucosa register`), one file per phase:
# the image side's pq estimation (pq_image.cpp), the model side
# (model_view.cpp, albedo_map.cpp), the objective (objective.cpp), the
# optimiser (optimiser.cpp), the tracker and its searches (tracker.cpp,
# initial_search.cpp), and the pose arithmetic they share (pose.cpp), with
# their private declarations in phases.hpp. Then video files (video.cpp),
# the run's file and report (register_io.cpp), and the synthetic patient
# (patient.cpp), which renders a bronchoscopy to run register -> fit ->
# categories on.
find_package(Eigen3 CONFIG REQUIRED)
# FFmpeg's libraries (Debian's libav*-dev): bronchoscopy video files for mucosa register.
find_package(PkgConfig REQUIRED)
pkg_check_modules(MUCOSA_FFMPEG REQUIRED IMPORTED_TARGET GLOBAL libavformat libavcodec libswscale libavutil)
set(mucosa_register_phases
  ${CMAKE_CURRENT_LIST_DIR}/pq_image.cpp
  ${CMAKE_CURRENT_LIST_DIR}/model_view.cpp
  ${CMAKE_CURRENT_LIST_DIR}/albedo_map.cpp
  ${CMAKE_CURRENT_LIST_DIR}/objective.cpp
  ${CMAKE_CURRENT_LIST_DIR}/optimiser.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tracker.cpp
  ${CMAKE_CURRENT_LIST_DIR}/initial_search.cpp
  ${CMAKE_CURRENT_LIST_DIR}/pose.cpp)
target_sources(mucosa_register PRIVATE
  ${mucosa_register_phases}
  ${CMAKE_CURRENT_LIST_DIR}/register_io.cpp
  ${CMAKE_CURRENT_LIST_DIR}/patient.cpp
  ${CMAKE_CURRENT_LIST_DIR}/video.cpp)
target_link_libraries(mucosa_register PRIVATE Eigen3::Eigen PkgConfig::MUCOSA_FFMPEG)
# The registration's per-pixel and per-triangle loops are reached by no fuzz
# harness (fuzz/CMakeLists.txt lists what each one parses), so in the 'fuzz'
# preset they keep AddressSanitizer and UBSan but not libFuzzer's coverage
# instrumentation, which there only slowed the sanitized test run (its
# comparison hooks alone were a tenth of a registration's time). The same
# for the depth pass (src/raster), back-projection and the texture
# (src/fit) and the synthetic patient.
if(MUCOSA_BUILD_FUZZ)
  set_source_files_properties(${mucosa_register_phases} ${CMAKE_CURRENT_LIST_DIR}/patient.cpp
    PROPERTIES COMPILE_OPTIONS -fno-sanitize=fuzzer-no-link)
endif()
