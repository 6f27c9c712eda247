include(CMakePackageConfigHelpers)

install(TARGETS mucosa EXPORT mucosaTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/mucosa
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES ${PROJECT_BINARY_DIR}/include/mucosa/version.hpp
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/mucosa)

set(MUCOSA_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/mucosa)
install(EXPORT mucosaTargets NAMESPACE mucosa:: DESTINATION ${MUCOSA_CMAKE_DIR})
configure_package_config_file(cmake/mucosaConfig.cmake.in
  ${PROJECT_BINARY_DIR}/mucosaConfig.cmake INSTALL_DESTINATION ${MUCOSA_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/mucosaConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/mucosaConfig.cmake
  ${PROJECT_BINARY_DIR}/mucosaConfigVersion.cmake DESTINATION ${MUCOSA_CMAKE_DIR})
