"""A sweep on a real Slurm: a single-node cluster (Debian's slurmctld, slurmd and munge, configured
here in a temporary folder with its own munge socket and ports, run as root), a sweep written
with `--manifest slurm`, submitted with `sbatch --wait`, aggregated with `--aggregate-only`, and
its results.csv equal to the same sweep run locally (timings aside); then one run removed and
the sweep resumed on Slurm with the same rules (only that run submitted again); then a sweep
cancelled mid-way with `scancel` and submitted again, nothing lost."""
import csv
import json
import os
import pathlib
import shutil
import socket
import subprocess
import tempfile
import time
import unittest

DSNAKE = os.environ.get("DSNAKE_EXE", "build/release/experiments/dsnake")
TIMINGS = {"field_s", "evolve_s", "metrics_s", "total_s"}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def rows(path):
    with open(path, newline="") as f:
        return [{k: v for k, v in r.items() if k not in TIMINGS} for r in csv.DictReader(f)]


class SingleNodeSlurm:
    """munged, slurmctld and slurmd on this machine, with everything under `root`."""

    def __init__(self, root):
        self.root = pathlib.Path(root)
        self.env = dict(os.environ, SLURM_CONF=str(self.root / "slurm.conf"))
        self.pids = []

    def start(self):
        missing = [b for b in ("munged", "slurmctld", "slurmd", "sbatch") if not shutil.which(b)]
        if missing:
            raise AssertionError("Slurm is not installed (missing %s): bash scripts/setup.sh installs slurmctld, "
                                 "slurmd and munge" % ", ".join(missing))
        if os.geteuid() != 0:
            raise AssertionError("the single-node Slurm of this test runs its daemons as root")
        r = self.root
        for d in ("state", "spool", "log"):
            (r / d).mkdir(parents=True)
        shutil.copy("/etc/munge/munge.key", r / "munge.key")
        os.chmod(r / "munge.key", 0o600)
        subprocess.run(["munged", "--force", "--socket=%s" % (r / "munge.socket"), "--key-file=%s" % (r / "munge.key"),
                        "--pid-file=%s" % (r / "munged.pid"), "--seed-file=%s" % (r / "munge.seed"),
                        "--log-file=%s" % (r / "log/munged.log")], check=True)
        self.pids.append(r / "munged.pid")
        host = socket.gethostname().split(".")[0]
        (r / "slurm.conf").write_text("\n".join([
            "ClusterName=dsnaketest", "SlurmctldHost=%s" % host, "SlurmUser=root", "SlurmdUser=root",
            "AuthType=auth/munge", "CredType=cred/munge", "AuthInfo=socket=%s" % (r / "munge.socket"),
            "SlurmctldPort=%d" % free_port(), "SlurmdPort=%d" % free_port(),
            "StateSaveLocation=%s" % (r / "state"), "SlurmdSpoolDir=%s" % (r / "spool"),
            "SlurmctldPidFile=%s" % (r / "slurmctld.pid"), "SlurmdPidFile=%s" % (r / "slurmd.pid"),
            "SlurmctldLogFile=%s" % (r / "log/slurmctld.log"), "SlurmdLogFile=%s" % (r / "log/slurmd.log"),
            "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none", "SelectType=select/cons_tres",
            "SelectTypeParameters=CR_Core_Memory", "JobAcctGatherType=jobacct_gather/none",
            "AccountingStorageType=accounting_storage/none", "MpiDefault=none", "ReturnToService=2",
            "NodeName=%s CPUs=%d RealMemory=4096 State=UNKNOWN" % (host, os.cpu_count()),
            "PartitionName=test Nodes=%s Default=YES MaxTime=INFINITE State=UP" % host, ""]))
        conf = str(r / "slurm.conf")
        subprocess.run(["slurmctld", "-f", conf], check=True, env=self.env)
        self.pids.append(r / "slurmctld.pid")
        subprocess.run(["slurmd", "-f", conf], check=True, env=self.env)
        self.pids.append(r / "slurmd.pid")
        deadline = time.time() + 60
        while time.time() < deadline:
            state = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True, env=self.env).stdout
            if state.strip() == "idle":
                return
            time.sleep(0.5)
        raise AssertionError("the node did not come up: " + (r / "log/slurmctld.log").read_text()[-2000:])

    def stop(self):
        for pid_file in reversed(self.pids):
            try:
                os.kill(int(pid_file.read_text()), 15)
            except (OSError, ValueError):
                pass
        time.sleep(0.5)

    def sbatch(self, script, cwd):
        """Submits without waiting; returns the job id."""
        done = subprocess.run(["sbatch", "--parsable", str(script)], cwd=cwd, capture_output=True, text=True,
                              env=self.env, timeout=60)
        if done.returncode != 0:
            raise AssertionError("sbatch failed: " + done.stdout + done.stderr)
        return done.stdout.strip().split(";")[0]

    def wait_gone(self, job, timeout=60):
        """Waits until no task of the job is queued or running."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            q = subprocess.run(["squeue", "-h", "-j", job], capture_output=True, text=True, env=self.env)
            if q.returncode == 0 and not q.stdout.strip():
                return
            if q.returncode != 0 and "Invalid job id" in q.stderr:
                return
            time.sleep(0.2)
        raise AssertionError(f"job {job} still in the queue after {timeout} s")

    def sbatch_wait(self, script, cwd):
        done = subprocess.run(["sbatch", "--wait", str(script)], cwd=cwd, capture_output=True, text=True,
                              env=self.env, timeout=300)
        if done.returncode != 0:
            raise AssertionError("sbatch failed: " + done.stdout + done.stderr)
        return done.stdout


class SlurmSweepTest(unittest.TestCase):
    def test_a_sweep_on_slurm_equals_the_local_sweep_and_resumes(self):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = pathlib.Path(tmp)
            experiment = {
                "name": "tiny", "dimension": 2, "seed": 1,
                "image": {"phantom": "square", "size": [64, 64], "half_width": 16, "blur": 1.5},
                "template": {"phantom": "circle", "radius": 22, "vertices": 32, "center": [31.5, 31.5]},
                "field": {"type": "gradient", "sigma": 2.0},
                "energies": [{"type": "internal", "weight": 1.0, "alpha": 0.1, "beta": 0.01},
                             {"type": "external", "weight": 1.0, "tau": 3.0}],
                "phases": [{"name": "fit", "iterations": 40, "tolerance": 0.0}],
                "success": {"mean_surface_distance": 1.0, "dice": 0.9}, "output": {"figures": False}}
            (tmp / "exp.json").write_text(json.dumps(experiment))
            (tmp / "sweep.json").write_text(json.dumps({
                "base": "exp.json", "corruptions": [[], [{"type": "noise", "sigma": 30}]], "seeds": [0, 1, 2],
                "methods": {"snake": {}, "stiff": {"overrides": {"energies[0].beta": 0.1}}}}))
            sweep = str(tmp / "sweep.json")
            subprocess.run([DSNAKE, "sweep", sweep, "--out", str(tmp / "local"), "-j", "2", "--quiet"], check=True)

            slurm = SingleNodeSlurm(tmp / "slurm")
            slurm.start()
            try:
                out = tmp / "cluster"
                # Three runs per array task: four tasks, at most two at once.
                subprocess.run([DSNAKE, "sweep", sweep, "--out", str(out), "--manifest", "slurm",
                                "--slurm-lines-per-task", "3", "--slurm-max-running", "2", "--quiet"], check=True)
                script = (out / "sweep.slurm").read_text()
                for line in ("#SBATCH --array=0-3%2", "#SBATCH --cpus-per-task=1", "#SBATCH --time=60",
                             "#SBATCH --mem=4096M"):
                    self.assertIn(line + "\n", script)
                slurm.sbatch_wait(out / "sweep.slurm", out)
                self.assertEqual(len(list((out / "logs").glob("slurm-*_*.log"))), 4)
                subprocess.run([DSNAKE, "sweep", sweep, "--out", str(out), "--aggregate-only", "--quiet"], check=True)
                local, cluster = rows(tmp / "local/results.csv"), rows(out / "results.csv")
                self.assertEqual(len(cluster), 12)
                self.assertEqual(cluster, local)

                # Resumed with the same rules: only the removed run is submitted again, with the
                # resources measured from the eleven finished ones.
                removed = cluster[4]["run_id"]
                shutil.rmtree(out / "runs" / removed)
                subprocess.run([DSNAKE, "sweep", sweep, "--out", str(out), "--manifest", "slurm", "--quiet"], check=True)
                self.assertEqual(len((out / "manifest.txt").read_text().splitlines()), 1)
                script = (out / "sweep.slurm").read_text()
                self.assertIn("#SBATCH --array=0-0\n", script)
                self.assertIn("from 11 finished runs", script)
                slurm.sbatch_wait(out / "sweep.slurm", out)
                subprocess.run([DSNAKE, "sweep", sweep, "--out", str(out), "--aggregate-only", "--quiet"], check=True)
                self.assertEqual(rows(out / "results.csv"), local)

                # Cancelled mid-way and submitted again: one run per task, one task at a time;
                # `scancel` once some runs have finished and others have not, then the manifest of
                # the unfinished runs is submitted and the aggregate is the local one, nothing lost.
                again = tmp / "cancelled"
                subprocess.run([DSNAKE, "sweep", sweep, "--out", str(again), "--manifest", "slurm",
                                "--slurm-lines-per-task", "1", "--slurm-max-running", "1", "--quiet"], check=True)
                job = slurm.sbatch(again / "sweep.slurm", again)
                finished = lambda: len(list((again / "runs").glob("*/result.json")))
                deadline = time.time() + 120
                while finished() < 3 and time.time() < deadline:
                    time.sleep(0.2)
                subprocess.run(["scancel", job], env=slurm.env, check=True)
                slurm.wait_gone(job)
                done_before = finished()
                self.assertGreaterEqual(done_before, 3)
                self.assertLess(done_before, 12, "the cancel came after every run had finished")
                subprocess.run([DSNAKE, "sweep", sweep, "--out", str(again), "--manifest", "slurm", "--quiet"], check=True)
                self.assertEqual(len((again / "manifest.txt").read_text().splitlines()), 12 - done_before)
                slurm.sbatch_wait(again / "sweep.slurm", again)
                subprocess.run([DSNAKE, "sweep", sweep, "--out", str(again), "--aggregate-only", "--quiet"], check=True)
                self.assertEqual(rows(again / "results.csv"), local)
                self.assertEqual(list((again / "runs").glob("*.partial-*")), [])
            finally:
                slurm.stop()


if __name__ == "__main__":
    unittest.main()
