#!/usr/bin/env bash
# Snakemake's cluster-status command for Slurm (config.yaml): prints running, success or
# failed for one job. Without it snakemake waits for a marker file the job writes when it
# ends, and a job Slurm kills (time or memory limit, a lost node) never writes one: the
# workflow would wait forever and the retry (restart-times) never fire.
# Usage: slurm-status.sh JOBID   (sbatch --parsable prints "ID" or "ID;CLUSTER")
set -uo pipefail
id=${1%%;*}
# Accounting knows every job, running or ended; -X: the job, not its steps.
state=$(sacct -j "$id" -X --noheader --parsable2 --format=State 2>/dev/null | head -n 1)
if [ -z "$state" ]; then
  # No accounting (or not recorded yet): a job the queue still lists is running; one it
  # no longer lists has ended, and snakemake then checks its outputs, so a killed job
  # is still found failed (missing output) and retried.
  state=$(squeue -h -j "$id" -o %T 2>/dev/null | head -n 1)
  [ -n "$state" ] || state=COMPLETED
fi
case ${state%% *} in  # "CANCELLED by 1234": the first word
  COMPLETED) echo success ;;
  PENDING | CONFIGURING | RUNNING | COMPLETING | SUSPENDED | REQUEUED | REQUEUE_HOLD | REQUEUE_FED | RESIZING | \
    SIGNALING | STAGE_OUT | STOPPED | RESV_DEL_HOLD) echo running ;;
  *) echo failed ;;  # FAILED, TIMEOUT, OUT_OF_MEMORY, NODE_FAIL, CANCELLED, PREEMPTED, BOOT_FAIL, DEADLINE
esac
