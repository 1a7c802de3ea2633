# What the module does to its process: large buffers advised onto huge pages as the command line
# has them (python/huge_pages.cpp), and Ctrl-C stopping a run at its next iteration.
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import dsnake

SOURCE_DIR = pathlib.Path(__file__).resolve().parents[2]


def advised_mappings():
    """Sizes (bytes) of this process's mappings that carry the huge-page advice (VmFlags "hg")."""
    sizes, size = [], 0
    with open("/proc/self/smaps") as f:
        for line in f:
            if line.startswith("Size:"):
                size = int(line.split()[1]) * 1024
            elif line.startswith("VmFlags:") and " hg" in line:
                sizes.append(size)
    return sizes


def test_a_volume_sized_buffer_is_advised_onto_huge_pages():
    before = advised_mappings()
    # The Image's voxels: 64 MB of float32, copied into the library's own buffer.
    image = dsnake.Image(np.zeros((64, 512, 512), np.float32))
    after = advised_mappings()
    # The advice covers the buffer's whole 2 MB pages: a mapping of its own, all but its ends.
    assert len(after) == len(before) + 1 and max(after) >= 60 << 20
    del image
    assert advised_mappings() == before  # unmapped with the image
    # A small buffer is left to malloc's ordinary pages.
    small = dsnake.Image(np.zeros((16, 16, 16), np.float32))
    assert advised_mappings() == before and small.array.size == 4096


@pytest.mark.parametrize("progress", [True, False])
def test_ctrl_c_stops_a_run_at_its_next_iteration(progress, tmp_path):
    # A child that runs the lung phantom (a field solve of about a second, then about 40
    # iterations); Ctrl-C (SIGINT) once the first iteration is printed (with a progress callback,
    # which the interrupt reaches in Python) or half a second after the run started (without one:
    # the interrupt waits in the solve until the run looks for it at its first iteration).
    callback = "progress=lambda i: print(i['iteration'], flush=True)" if progress else ""
    child = subprocess.Popen(
        [sys.executable, "-u", "-c",
         "import sys, dsnake\n"
         "print('start', flush=True)\n"
         f"dsnake.run(sys.argv[1], out=sys.argv[2], {callback})\n"
         "print('finished')\n",
         str(SOURCE_DIR / "experiments/paper/lung_dsnake.json"), str(tmp_path / "out")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "start"
    if progress:
        assert child.stdout.readline().strip() == "1"
    else:
        time.sleep(0.5)
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=120)
    assert "KeyboardInterrupt" in err and "finished" not in out
    assert not (tmp_path / "out" / "result.json").exists()  # stopped before its end, nothing written
    if progress:
        assert out.split() in ([], ["2"])  # stopped at once (the "1" was read above)
    assert child.returncode == -signal.SIGINT  # python3's exit on an uncaught KeyboardInterrupt
