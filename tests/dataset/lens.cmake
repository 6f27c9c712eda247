# The endoscope lens models (pinhole, OpenCV fisheye, Scaramuzza).
mucosa_add_test(test_dataset_lens ${CMAKE_CURRENT_LIST_DIR}/lens_test.cpp)

# lens_points: Mucosa's projection of points read from stdin, for the OpenCV
# cross-check below only (a test tool, not the CLI). Built with the test.
add_executable(lens_points ${CMAKE_CURRENT_LIST_DIR}/lens_points.cpp)
target_link_libraries(lens_points PRIVATE mucosa::mucosa mucosa_warnings mucosa_sanitizers)
add_dependencies(test_dataset_lens lens_points)

# The pinhole (k1, k2) and fisheye models against cv2.projectPoints and
# cv2.fisheye.projectPoints, with Debian's python (python3-opencv,
# python3-numpy): a missing module fails, never skips.
add_test(NAME dataset_lens_opencv_crosscheck
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/opencv_lens_check.py $<TARGET_FILE:lens_points>
          ${CMAKE_CURRENT_BINARY_DIR}/opencv_lens)
set_tests_properties(dataset_lens_opencv_crosscheck PROPERTIES TIMEOUT 120 LABELS dataset)

# Ground truth through a lens (lens_points --truth) against OpenCV: the mesh
# point each pixel names projects onto it (cv2.fisheye.projectPoints,
# cv2.projectPoints), and OpenCV's ray meets that triangle first.
add_test(NAME dataset_lens_truth_opencv_crosscheck
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/opencv_lens_truth_check.py $<TARGET_FILE:lens_points>
          ${CMAKE_CURRENT_BINARY_DIR}/opencv_lens_truth)
set_tests_properties(dataset_lens_truth_opencv_crosscheck PROPERTIES TIMEOUT 120 LABELS "dataset;slow")
