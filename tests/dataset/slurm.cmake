# mucosa dataset slurm on a real Slurm (issue 17, docs/slurm.md): a 4-task job
# array over a plan, one task SIGKILLed mid-shard and requeued, must verify and
# match one `mucosa dataset run` byte for byte. The test starts its own
# single-node Slurm (scripts/slurm-single-node: root, Debian's slurm-wlm and
# munge) and fails, never skips, when it cannot. One Slurm test at a time
# (RESOURCE_LOCK); `ctest -L slurm` runs it alone, `-LE slurm` leaves it out.
add_test(NAME dataset_slurm_e2e
  COMMAND /bin/bash ${CMAKE_CURRENT_LIST_DIR}/slurm_e2e.sh $<TARGET_FILE:mucosa_cli>
          ${PROJECT_SOURCE_DIR}/scripts/slurm-single-node)
set_tests_properties(dataset_slurm_e2e PROPERTIES RESOURCE_LOCK slurm TIMEOUT 900 LABELS "dataset;slurm;slow")
