# mucosa dataset slurm on a real Slurm (docs/slurm.md): a 4-task job
# array over a plan, one task SIGKILLed mid-shard and requeued, must verify and
# match one `mucosa dataset run` byte for byte. The test starts its own
# single-node Slurm (scripts/slurm-single-node: root, Debian's slurm-wlm and
# munge) and fails, never skips, when it cannot. One Slurm test at a time
# (RESOURCE_LOCK), and alone (RUN_SERIAL): the kill must land between the
# victim's first finished frame and its last, which a test beside it on two
# cores can delay past the shard's end. `ctest -L slurm` runs it alone,
# `-LE slurm` leaves it out.
add_test(NAME dataset_slurm_e2e
  COMMAND /bin/bash ${CMAKE_CURRENT_LIST_DIR}/slurm_e2e.sh $<TARGET_FILE:mucosa_cli>
          ${PROJECT_SOURCE_DIR}/scripts/slurm-single-node)
set_tests_properties(dataset_slurm_e2e PROPERTIES RESOURCE_LOCK slurm RUN_SERIAL TRUE TIMEOUT 900
                                                   LABELS "dataset;slurm;slow")
