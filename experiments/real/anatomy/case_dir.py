"""Writing a case folder whole or not at all, for the scripts that derive one case from another
(scale_case.py, acquire_case.py)."""
import os
import shutil
import tempfile


def replace_case(out_dir, case, write):
    """Calls write(staging) on a fresh folder inside out_dir, then puts it in place of
    out_dir/<case's name> (an earlier copy is replaced); returns that path. A failure inside
    write() leaves the earlier copy, if any, as it was."""
    target = os.path.join(out_dir, os.path.basename(os.path.normpath(case)))
    os.makedirs(out_dir, exist_ok=True)
    staging = tempfile.mkdtemp(dir=out_dir, prefix=".case_")
    try:
        write(staging)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    if os.path.exists(target):
        shutil.rmtree(target)
    os.rename(staging, target)
    return target
