# study: perceptual realism study kit (plan, web runner, statistics, report).
find_package(SQLite3 REQUIRED)
# Header-only Boost: Math (chi-squared, normal, binomial), Beast and Asio (the
# study server's HTTP: async, per-request deadlines and size limits).
find_package(Boost 1.74 REQUIRED)
find_package(Threads REQUIRED)

# The web page, embedded into the library at build time.
set(mucosa_study_web
  ${CMAKE_CURRENT_LIST_DIR}/web/index.html
  ${CMAKE_CURRENT_LIST_DIR}/web/app.js
  ${CMAKE_CURRENT_LIST_DIR}/web/style.css)
set(mucosa_study_web_cpp ${CMAKE_CURRENT_BINARY_DIR}/study/web_assets.cpp)
add_custom_command(OUTPUT ${mucosa_study_web_cpp}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_CURRENT_BINARY_DIR}/study
  COMMAND ${CMAKE_COMMAND} -DOUT=${mucosa_study_web_cpp} "-DFILES=${mucosa_study_web}"
          -P ${CMAKE_CURRENT_LIST_DIR}/embed_web.cmake
  DEPENDS ${mucosa_study_web} ${CMAKE_CURRENT_LIST_DIR}/embed_web.cmake
  COMMENT "Embedding the study web page" VERBATIM)
set_source_files_properties(${mucosa_study_web_cpp} PROPERTIES
  INCLUDE_DIRECTORIES ${CMAKE_CURRENT_LIST_DIR})

target_sources(mucosa_study PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/plan.cpp
  ${CMAKE_CURRENT_LIST_DIR}/ranks.cpp
  ${CMAKE_CURRENT_LIST_DIR}/friedman.cpp
  ${CMAKE_CURRENT_LIST_DIR}/wilcoxon.cpp
  ${CMAKE_CURRENT_LIST_DIR}/mann_whitney.cpp
  ${CMAKE_CURRENT_LIST_DIR}/roc.cpp
  ${CMAKE_CURRENT_LIST_DIR}/binomial.cpp
  ${CMAKE_CURRENT_LIST_DIR}/analysis.cpp
  ${CMAKE_CURRENT_LIST_DIR}/data_io.cpp
  ${CMAKE_CURRENT_LIST_DIR}/report.cpp
  ${CMAKE_CURRENT_LIST_DIR}/store.cpp
  ${CMAKE_CURRENT_LIST_DIR}/http_handler.cpp
  ${CMAKE_CURRENT_LIST_DIR}/server.cpp
  ${mucosa_study_web_cpp})
target_link_libraries(mucosa_study PRIVATE SQLite::SQLite3 Boost::headers Threads::Threads)
