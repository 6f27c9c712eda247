# fit: patient texture and shading from registered frames (`mucosa fit`):
# back-projection, the joint robust solve (Ceres), the atlas, the report;
# and the study's image categories rendered at the frames' poses
# (`mucosa categories`).
find_package(Ceres CONFIG REQUIRED)
find_package(Eigen3 CONFIG REQUIRED)
target_sources(mucosa_fit PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/backproject.cpp
  ${CMAKE_CURRENT_LIST_DIR}/solve.cpp
  ${CMAKE_CURRENT_LIST_DIR}/texture.cpp
  ${CMAKE_CURRENT_LIST_DIR}/fit.cpp
  ${CMAKE_CURRENT_LIST_DIR}/report.cpp
  ${CMAKE_CURRENT_LIST_DIR}/categories.cpp)
target_link_libraries(mucosa_fit PRIVATE Ceres::ceres Eigen3::Eigen)
# Per-pixel loops no fuzz harness reaches: see src/register/sources.cmake.
if(MUCOSA_BUILD_FUZZ)
  set_source_files_properties(
    ${CMAKE_CURRENT_LIST_DIR}/backproject.cpp ${CMAKE_CURRENT_LIST_DIR}/texture.cpp
    PROPERTIES COMPILE_OPTIONS -fno-sanitize=fuzzer-no-link)
endif()
