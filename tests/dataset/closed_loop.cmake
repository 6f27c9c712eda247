# Closed loop: a dataset rendered in the brdf mode with known rho and delta
# goes through `mucosa fit` unchanged and gives them back (both through the CLI).
mucosa_add_test(test_dataset_closed_loop ${CMAKE_CURRENT_LIST_DIR}/closed_loop_test.cpp)
add_dependencies(test_dataset_closed_loop mucosa_cli)
