# camera: endoscope camera and tip light, pose lists and centerline fly-throughs.
find_package(glm CONFIG REQUIRED)
target_sources(mucosa_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/camera.cpp)
target_link_libraries(mucosa_core PRIVATE $<BUILD_INTERFACE:glm::glm>)
