# --orient lumen: the surface faces the lumen for cameras inside, decided from
# the centerline (the CT airway and the phantom, as they come and inside out).
mucosa_add_test(test_dataset_orient ${CMAKE_CURRENT_LIST_DIR}/orient_test.cpp)
