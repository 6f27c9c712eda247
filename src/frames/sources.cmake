# frames: registered endoscope frames (intrinsics, poses, the camera's
# response) and the frames, camera and pose files `mucosa register` writes and
# `mucosa fit`, `mucosa dataset` and `mucosa render` read; the pose arithmetic
# and the GL camera of a frame.
target_sources(mucosa_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/frames.cpp)
