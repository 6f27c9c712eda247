# Run by CTest (a TEST_INCLUDE_FILES script that mucosa_add_test writes) after
# a test binary's discovered tests are defined: gives each its binary's labels
# (mucosa_labels), plus slow where its name matches a pattern of mucosa_slow,
# less sanitize where it matches one of mucosa_unsanitized (tests/labels.cmake).
# Before the binary is built CTest has only its placeholder test, and this
# does nothing.
if(EXISTS "${mucosa_discovered}")
  file(STRINGS "${mucosa_discovered}" mucosa_lines REGEX "^add_test\\(")
  foreach(mucosa_line IN LISTS mucosa_lines)
    if(mucosa_line MATCHES "^add_test\\(\\[=\\[([^]]+)\\]=\\]")
      set(mucosa_test "${CMAKE_MATCH_1}")
      set(mucosa_own ${mucosa_labels})
      foreach(mucosa_re IN LISTS mucosa_unsanitized)
        if(mucosa_test MATCHES "${mucosa_re}")
          list(REMOVE_ITEM mucosa_own sanitize)
        endif()
      endforeach()
      foreach(mucosa_re IN LISTS mucosa_slow)
        if(mucosa_test MATCHES "${mucosa_re}")
          list(APPEND mucosa_own slow)
        endif()
      endforeach()
      set_tests_properties("${mucosa_test}" PROPERTIES LABELS "${mucosa_own}")
    endif()
  endforeach()
endif()
