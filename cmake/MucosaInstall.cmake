include(CMakePackageConfigHelpers)

# One export set per layer, so find_package(mucosa COMPONENTS core) loads (and,
# for a static build, finds the dependencies of) that layer alone.
foreach(layer IN ITEMS core scene render dataset tune fit register study)
  install(TARGETS mucosa_${layer} EXPORT mucosa_${layer}_targets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
    INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endforeach()
install(TARGETS mucosa EXPORT mucosa_mucosa_targets)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/mucosa
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES ${PROJECT_BINARY_DIR}/include/mucosa/version.hpp
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/mucosa)

set(MUCOSA_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/mucosa)
foreach(layer IN ITEMS core scene render dataset tune fit register study mucosa)
  install(EXPORT mucosa_${layer}_targets NAMESPACE mucosa:: DESTINATION ${MUCOSA_CMAKE_DIR}
    FILE mucosa-${layer}-targets.cmake)
endforeach()
configure_package_config_file(cmake/mucosaConfig.cmake.in
  ${PROJECT_BINARY_DIR}/mucosaConfig.cmake INSTALL_DESTINATION ${MUCOSA_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/mucosaConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/mucosaConfig.cmake
  ${PROJECT_BINARY_DIR}/mucosaConfigVersion.cmake DESTINATION ${MUCOSA_CMAKE_DIR})
