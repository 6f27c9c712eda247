# Warnings and sanitizers are INTERFACE targets linked PRIVATE, never edits of
# CMAKE_CXX_FLAGS (STYLE.md, "Shape").
add_library(mucosa_warnings INTERFACE)
target_compile_options(mucosa_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion>)

add_library(mucosa_sanitizers INTERFACE)
if(MUCOSA_SANITIZE)
  target_compile_options(mucosa_sanitizers INTERFACE
    -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  target_link_options(mucosa_sanitizers INTERFACE -fsanitize=address,undefined)
endif()
# Fuzzing (fuzz/, clang only): the library and the harnesses carry libFuzzer's
# coverage instrumentation; only the harnesses link libFuzzer's main.
if(MUCOSA_BUILD_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "MUCOSA_BUILD_FUZZ needs clang (libFuzzer): use the 'fuzz' preset")
  endif()
  target_compile_options(mucosa_sanitizers INTERFACE -fsanitize=fuzzer-no-link)
endif()

# Floating point is reproducible by construction: no contraction of a*b+c into
# FMA, so the vectorised noise path and the scalar reference (a port of Java,
# which never contracts) round identically (see docs/theory.md, "Exactness").
add_library(mucosa_fp INTERFACE)
target_compile_options(mucosa_fp INTERFACE $<$<CXX_COMPILER_ID:GNU,Clang>:-ffp-contract=off -fno-math-errno>)
