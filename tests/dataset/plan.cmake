# mucosa dataset plan / run / verify: sharding gives the same bytes, checksums
# find what is missing or damaged, bad requests are refused.
mucosa_add_test(test_dataset_plan ${CMAKE_CURRENT_LIST_DIR}/plan_test.cpp)
target_include_directories(test_dataset_plan PRIVATE ${PROJECT_SOURCE_DIR}/tests/cli)
