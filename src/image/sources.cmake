target_sources(mucosa_core PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/image.cpp
  ${CMAKE_CURRENT_LIST_DIR}/png_write.cpp
  ${CMAKE_CURRENT_LIST_DIR}/deflate_huffman.cpp
  ${CMAKE_CURRENT_LIST_DIR}/png_read.cpp
  ${CMAKE_CURRENT_LIST_DIR}/exr.cpp)
