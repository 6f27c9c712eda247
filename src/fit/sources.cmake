find_package(Ceres CONFIG REQUIRED)
find_package(Eigen3 CONFIG REQUIRED)
# FFmpeg's libraries (Debian's libav*-dev): bronchoscopy video files for mucosa register.
find_package(PkgConfig REQUIRED)
pkg_check_modules(MUCOSA_FFMPEG REQUIRED IMPORTED_TARGET GLOBAL libavformat libavcodec libswscale libavutil)
target_sources(mucosa_fit PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/frames.cpp
  ${CMAKE_CURRENT_LIST_DIR}/raster.cpp
  ${CMAKE_CURRENT_LIST_DIR}/backproject.cpp
  ${CMAKE_CURRENT_LIST_DIR}/solve.cpp
  ${CMAKE_CURRENT_LIST_DIR}/texture.cpp
  ${CMAKE_CURRENT_LIST_DIR}/fit.cpp
  ${CMAKE_CURRENT_LIST_DIR}/report.cpp
  ${CMAKE_CURRENT_LIST_DIR}/categories.cpp
  ${CMAKE_CURRENT_LIST_DIR}/highlight_stats.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tune.cpp
  ${CMAKE_CURRENT_LIST_DIR}/register.cpp
  ${CMAKE_CURRENT_LIST_DIR}/register_io.cpp
  ${CMAKE_CURRENT_LIST_DIR}/patient.cpp
  ${CMAKE_CURRENT_LIST_DIR}/video.cpp)
target_link_libraries(mucosa_fit PRIVATE Ceres::ceres Eigen3::Eigen PkgConfig::MUCOSA_FFMPEG)
