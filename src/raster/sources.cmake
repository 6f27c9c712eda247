# raster: the CPU z-buffer (which triangle each pixel of a pinhole camera
# sees): the depth pass of back-projection and registration, and of the
# datasets' pinhole ground truth.
target_sources(mucosa_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/raster.cpp)
# Reached by no fuzz harness (fuzz/CMakeLists.txt lists what each one
# parses): see src/register/sources.cmake.
if(MUCOSA_BUILD_FUZZ)
  set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/raster.cpp
    PROPERTIES COMPILE_OPTIONS -fno-sanitize=fuzzer-no-link)
endif()
