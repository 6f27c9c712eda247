# Which stage of scripts/test runs which test (tests/README.md, "Labels").
# Every test binary's tests carry its folder's name (core, mesh, render, ...)
# and, from the lists below:
#
#   sanitize  the sanitizer stage (clang, AddressSanitizer + UBSan: the
#             'sanitize' presets) runs them beside every fuzz target's corpus
#             and brief run: the tests of untrusted input (parsers, importers,
#             the tool's error paths), memory ownership and concurrency (core,
#             image, the thread pools, the sandbox, the study server). The long
#             GL and registration sequences are not repeated there: they run
#             in the release build, and the code they would add under ASan is
#             loops over buffers whose sizes the sanitized tests already check.
#   slow      over about 3 s on its own in the release build on a 2-core
#             machine: `scripts/test --quick` (`ctest --preset quick`) leaves
#             them out. Every one still runs in `scripts/test` and in CI.
#
# Patterns are CMake regular expressions on a test's full name (Suite.Test).
# Script tests (Python, shell, CMake) are labelled where they are added.

set(mucosa_sanitize_binaries
  test_core test_image test_noise test_reflectance test_mesh camera_tests shading_tests
  test_cli test_study test_dataset_lens test_dataset_export)

# Tests of those binaries the sanitizer stage leaves out: the phantom's
# generation and the renders (no untrusted input; minutes under ASan).
set(mucosa_unsanitized_test_mesh "^Phantom" "^MikkTSpace\\." "^GltfExport\\.Phantom" "^MeshCli\\.OrientLumen")
set(mucosa_unsanitized_test_cli "^DemoCli\\." "^RenderResume\\." "^CliOutput\\.(CountsAreSingular|AKilledRun)")
set(mucosa_unsanitized_camera_tests "^Camera\\.DefaultFlyThrough" "^Camera\\.Survey(VisitsEveryBranch|MovesContinuously)")

set(mucosa_slow_test_demo_patient ".")
set(mucosa_slow_test_cli "^DemoCli\\.")
set(mucosa_slow_test_mesh "^Phantom\\." "^PhantomCli\\." "^MikkTSpace\\.Phantom")
set(mucosa_slow_render_tests
  "^LensCli\\.RenderDraws" "^SpecularAntiAliasing\\.Flicker" "^RenderParity\\.(Procedural|FlatQuad)" "^RgbBits\\."
  "^RenderCli\\.(EveryMode|FramesThatWillNot)" "^RenderHighlights\\.Procedural")
set(mucosa_slow_test_fit "^Falloff\\." "^FitRecovery\\." "^AtlasShape\\.")
set(mucosa_slow_test_register
  "^RegisterCli\\." "^RegisterAlbedo\\." "^RegisterPose\\.(TheInitialSearch|NoPriorHolds|AFrameFacingTheWall|AFrameWithNoLumen|TheFramesUncertainty)"
  "^SyntheticPatient\\.(TheFirstFramesSearch|AFirstFramesCoarseJump)")
set(mucosa_slow_test_tune "^Tune\\.FitRecovers")
set(mucosa_slow_test_dataset_truth "^GroundTruthCli\\.")
set(mucosa_slow_test_dataset_orient "^OrientLumen\\.Phantom")
set(mucosa_slow_test_dataset_plan "^DatasetPlan\\.(AnySharding|Verify|WithFixedExposure)")
set(mucosa_slow_test_dataset_closed_loop "^ClosedLoop\\.")
set(mucosa_slow_test_dataset_colour "^ColourOutputs\\.")
