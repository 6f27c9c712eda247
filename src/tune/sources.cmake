# tune: how the reflectance map's noise and the specular lobe shape the
# highlights (`mucosa tune`): the realism tool's highlight statistics
# (highlight_stats.cpp) and the tuner that sweeps and fits the look with the
# renderer in the loop (tune.cpp). Its own layer: it measures the rendered
# look, so it needs the renderer but not Ceres, and neither the fit nor the
# registration uses it.
target_sources(mucosa_tune PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/frame_stats.cpp
  ${CMAKE_CURRENT_LIST_DIR}/highlight_stats.cpp
  ${CMAKE_CURRENT_LIST_DIR}/look.cpp
  ${CMAKE_CURRENT_LIST_DIR}/observer.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tune.cpp)
