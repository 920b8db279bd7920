#!/usr/bin/env python3
"""The CI examples in pipelines/ci (issue 45): linted offline, then run as far as they can
be without a hosted runner.

actionlint is not packaged for Debian 12 and GitLab's schema is not available offline, so
this is an equivalent check written for these two files: YAML that parses, only the keys
each service knows at each level, steps with exactly one of `uses`/`run`, `uses` pinned
to a ref, git installed before `actions/checkout` in a container job (the debian:12 image
has none, and checkout then cannot fetch submodules), submodules checked out
(`submodules:` / GIT_SUBMODULE_STRATEGY), the JUnit path the script writes being the one
published, and every shell script (the `run:`/`script:` lines, and the pipeline's
scripts) clean under shellcheck. Then the jobs' commands run here, in a layout like a
game project's (fissure/ as the submodule, assets/bundles/*.h5), with the build step
replaced by this build's fissure-bake: they must pass and write the published report.

usage: ci_examples_test.py FISSURE_BAKE REPOSITORY_ROOT
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

failures = []


def check(condition: bool, what: str) -> None:
    if not condition:
        failures.append(what)
        print(f"FAIL: {what}", file=sys.stderr)


# The keys each level may hold (GitHub's workflow syntax and GitLab's .gitlab-ci.yml
# reference, the subsets a job like these uses).
GITHUB_TOP = {"name", "on", "env", "jobs", "permissions", "concurrency", "defaults", "run-name"}
GITHUB_JOB = {"name", "runs-on", "container", "env", "steps", "needs", "if", "strategy", "timeout-minutes",
              "services", "permissions", "defaults", "outputs", "continue-on-error", "concurrency", "environment"}
GITHUB_STEP = {"name", "id", "if", "uses", "run", "with", "env", "shell", "working-directory", "continue-on-error",
               "timeout-minutes"}
GITLAB_JOB = {"stage", "image", "variables", "script", "before_script", "after_script", "artifacts", "rules",
              "only", "except", "tags", "needs", "dependencies", "cache", "services", "timeout", "retry",
              "allow_failure", "when", "interruptible", "extends", "environment", "coverage", "parallel"}
GITLAB_GLOBAL = {"stages", "variables", "default", "include", "workflow", "image", "services", "cache",
                 "before_script", "after_script"}
GITLAB_ARTIFACTS = {"when", "reports", "paths", "expire_in", "name", "expose_as", "untracked", "exclude", "public"}


def shellcheck(script: str, what: str) -> None:
    """shellcheck on a job's shell lines (bash; variables the CI sets are not errors)."""
    run = subprocess.run(["shellcheck", "--shell=bash", "--severity=warning", "-"], input=script,
                         capture_output=True, text=True)
    check(run.returncode == 0, f"{what}: shellcheck:\n{run.stdout}{run.stderr}")


def lint_github(path: Path) -> dict:
    workflow = yaml.safe_load(path.read_text())
    # YAML 1.1 reads the key `on` as True; GitHub reads it as "on".
    if True in workflow:
        workflow["on"] = workflow.pop(True)
    check(set(workflow) <= GITHUB_TOP, f"{path.name}: unknown top-level keys {set(workflow) - GITHUB_TOP}")
    check("on" in workflow and "jobs" in workflow, f"{path.name}: a workflow needs on: and jobs:")
    for job_id, job in workflow.get("jobs", {}).items():
        where = f"{path.name}: job {job_id}"
        check(set(job) <= GITHUB_JOB, f"{where}: unknown keys {set(job) - GITHUB_JOB}")
        check("runs-on" in job and isinstance(job.get("steps"), list), f"{where}: needs runs-on and a list of steps")
        checkout_at, git_at = None, None
        for i, step in enumerate(job.get("steps", [])):
            here = f"{where}, step {i + 1}"
            check(set(step) <= GITHUB_STEP, f"{here}: unknown keys {set(step) - GITHUB_STEP}")
            check(("uses" in step) != ("run" in step), f"{here}: exactly one of uses and run")
            if "uses" in step:
                check(re.fullmatch(r"[\w.-]+/[\w./-]+@[\w.-]+", step["uses"]) is not None,
                      f"{here}: uses {step['uses']!r} is not OWNER/REPO@REF")
                if step["uses"].startswith("actions/checkout@"):
                    checkout_at = i
                    check(step.get("with", {}).get("submodules") in (True, "true", "recursive"),
                          f"{here}: checkout without submodules (fissure/ is one)")
            else:
                check("with" not in step, f"{here}: with: belongs to a uses: step")
                shellcheck(step["run"], here)
                if re.search(r"apt-get install[^\n]*\bgit\b", step["run"]) and git_at is None:
                    git_at = i
            for text in map(str, step.values()):
                check(text.count("${{") == text.count("}}"), f"{here}: unbalanced ${{{{ }}}} in {text!r}")
        if "container" in job:
            check(git_at is not None and checkout_at is not None and git_at < checkout_at,
                  f"{where}: a container job must install git before actions/checkout")
    return workflow


def lint_gitlab(path: Path) -> dict:
    pipeline = yaml.safe_load(path.read_text())
    stages = pipeline.get("stages", [".pre", "build", "test", "deploy", ".post"])
    global_variables = pipeline.get("variables", {})
    jobs = {k: v for k, v in pipeline.items() if k not in GITLAB_GLOBAL and not k.startswith(".")}
    check(bool(jobs), f"{path.name}: no job")
    for name, job in jobs.items():
        where = f"{path.name}: job {name}"
        check(isinstance(job, dict) and set(job) <= GITLAB_JOB, f"{where}: unknown keys {set(job) - GITLAB_JOB}")
        check(job.get("stage", "test") in stages, f"{where}: stage {job.get('stage')!r} is not one of {stages}")
        check(isinstance(job.get("script"), list) and all(isinstance(s, str) for s in job["script"]),
              f"{where}: script must be a list of strings")
        variables = {**global_variables, **job.get("variables", {})}
        check(all(isinstance(v, (str, int, float)) for v in variables.values()), f"{where}: variables must be scalars")
        check(variables.get("GIT_SUBMODULE_STRATEGY") in ("normal", "recursive"),
              f"{where}: GIT_SUBMODULE_STRATEGY must be normal or recursive (fissure/ is a submodule)")
        artifacts = job.get("artifacts", {})
        check(set(artifacts) <= GITLAB_ARTIFACTS, f"{where}: unknown artifacts keys {set(artifacts) - GITLAB_ARTIFACTS}")
        shellcheck("\n".join(job.get("before_script", []) + job.get("script", [])), where)
    return jobs


def project(bake: str, root: Path, where: Path) -> Path:
    """A game project as the examples expect it: fissure/ (this repository) and bundles."""
    game = where / "game"
    (game / "assets" / "bundles").mkdir(parents=True)
    os.symlink(root, game / "fissure")
    for name, cage in (("bunny", "bunny-5k-cage-100.node"), ("prop", "bunny-5k-cage-10.node")):
        subprocess.run([bake, "-q", "bake", "--mesh", str(root / "data/meshes/bunny-5k.obj"),
                        "--cage", str(root / "data/cages" / cage), "-o", str(game / f"assets/bundles/{name}.h5"),
                        "--skip", "collision"], check=True, capture_output=True)
    return game


def is_setup(line: str) -> bool:
    """The lines a runner needs and this machine has: packages and fissure-bake's build."""
    return "apt-get" in line or "scripts/build.sh" in line


def run_lines(lines: list, env: dict, game: Path, what: str) -> None:
    script = "set -euo pipefail\n" + "\n".join(line for line in lines if not is_setup(line))
    run = subprocess.run(["bash", "-c", script], cwd=game, env=env, capture_output=True, text=True)
    check(run.returncode == 0, f"{what}: the job's commands failed ({run.returncode}):\n{run.stdout}{run.stderr}")


def main() -> int:
    bake, root = os.path.abspath(sys.argv[1]), Path(sys.argv[2]).resolve()
    if shutil.which("shellcheck") is None:
        print("FAIL: shellcheck is not installed (scripts/install-deps.sh installs it)", file=sys.stderr)
        return 1
    github = lint_github(root / "pipelines/ci/github-workflow.yml")
    gitlab = lint_gitlab(root / "pipelines/ci/gitlab-ci.yml")
    for script in ("pipelines/ci/check-bundles.sh", "pipelines/batch/profiles/slurm/slurm-status.sh"):
        shellcheck((root / script).read_text(), script)

    base = dict(os.environ)
    with tempfile.TemporaryDirectory() as tmp:
        game = project(bake, root, Path(tmp))
        for job_id, job in github["jobs"].items():
            lines = [s["run"].replace("$PWD/fissure/build/release/bake/fissure-bake", bake)
                     for s in job["steps"] if "run" in s]
            run_lines(lines, {**base, **{k: str(v) for k, v in job.get("env", {}).items()}}, game, f"github {job_id}")
            for step in job["steps"]:
                for report in str(step.get("with", {}).get("report_paths", "")).split(","):
                    if report:
                        check((game / report).is_file(), f"github {job_id}: no {report} to publish")
                        (game / report).unlink(missing_ok=True)
        for name, job in gitlab.items():
            lines = [line.replace("$PWD/fissure/build/release/bake/fissure-bake", bake) for line in job["script"]]
            run_lines(lines, {**base, **{k: str(v) for k, v in job.get("variables", {}).items()}}, game,
                      f"gitlab {name}")
            junit = job.get("artifacts", {}).get("reports", {}).get("junit")
            check(junit is not None and (game / junit).is_file(), f"gitlab {name}: no JUnit report {junit} written")
    print(f"{len(failures)} failure(s)" if failures else "the CI examples lint clean and run")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
