# Ground truth (depth, normals, masks, ids) of rendered frames: analytic scenes
# in C++; the OpenCV cross-check with Debian's python3-opencv (a missing
# module makes it fail, never skip).
mucosa_add_test(test_dataset_truth ${CMAKE_CURRENT_LIST_DIR}/ground_truth_test.cpp ${CMAKE_CURRENT_LIST_DIR}/lens_truth_test.cpp)
target_include_directories(test_dataset_truth PRIVATE ${PROJECT_SOURCE_DIR}/tests/cli)
add_test(NAME dataset_opencv_truth_check
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/opencv_truth_check.py $<TARGET_FILE:mucosa_cli>
          ${CMAKE_CURRENT_BINARY_DIR}/opencv_truth)
set_tests_properties(dataset_opencv_truth_check PROPERTIES TIMEOUT 300 LABELS "dataset;slow")
add_test(NAME dataset_opencv_fisheye_truth_check
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/opencv_fisheye_truth_check.py $<TARGET_FILE:mucosa_cli>
          ${CMAKE_CURRENT_BINARY_DIR}/opencv_fisheye_truth)
set_tests_properties(dataset_opencv_fisheye_truth_check PROPERTIES TIMEOUT 300 LABELS "dataset;slow")
