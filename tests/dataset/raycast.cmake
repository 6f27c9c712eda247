# The ray caster ground truth through a lens is computed with: the tree
# against brute force, analytic surfaces, watertightness.
mucosa_add_test(test_dataset_raycast ${CMAKE_CURRENT_LIST_DIR}/raycast_test.cpp)
