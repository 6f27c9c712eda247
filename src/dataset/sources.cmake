# Synthetic endoscopy datasets: per-frame ground truth (ground_truth.cpp) and
# the ray caster it sees through lenses with (raycast.cpp), the exporters to
# other tools' formats (export.cpp), the endoscope lens models (lens.cpp) and
# which side of a surface a camera in the lumen sees (orient.cpp).
# Part of the fit layer: it reads and writes the frames files `mucosa fit`
# reads.
target_sources(mucosa_fit PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/ground_truth.cpp
  ${CMAKE_CURRENT_LIST_DIR}/raycast.cpp
  ${CMAKE_CURRENT_LIST_DIR}/export.cpp
  ${CMAKE_CURRENT_LIST_DIR}/lens.cpp
  ${CMAKE_CURRENT_LIST_DIR}/orient.cpp)
