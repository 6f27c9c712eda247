# The exporters (TUM, COLMAP, nerfstudio).
mucosa_add_test(test_dataset_export export_test.cpp)

# The exported COLMAP and nerfstudio cameras against cv2.projectPoints, with
# Debian's python (python3-opencv, python3-numpy): a missing module fails, never
# skips.
add_test(NAME dataset_export_opencv_crosscheck
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/opencv_export_check.py $<TARGET_FILE:mucosa_cli>
          ${CMAKE_CURRENT_BINARY_DIR}/opencv_export)
set_tests_properties(dataset_export_opencv_crosscheck PROPERTIES TIMEOUT 120 LABELS dataset)
