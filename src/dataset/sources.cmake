# Synthetic endoscopy datasets: per-frame ground truth (ground_truth.cpp) and
# the exporters to other tools' formats (export.cpp). Part of the fit layer:
# it reads and writes the frames files `mucosa fit` reads.
target_sources(mucosa_fit PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/ground_truth.cpp
  ${CMAKE_CURRENT_LIST_DIR}/export.cpp)
