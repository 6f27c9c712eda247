# The renderer's own outputs beside the colour frame: its linear signal and
# the specular-highlight mask.
mucosa_add_test(test_dataset_colour ${CMAKE_CURRENT_LIST_DIR}/colour_outputs_test.cpp)
target_include_directories(test_dataset_colour PRIVATE ${PROJECT_SOURCE_DIR}/tests/cli)
