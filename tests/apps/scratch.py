"""Scratch directories for the end-to-end tests, removed when a test ends, pass or fail, so
that repeated test runs do not fill /tmp with run outputs."""
import shutil
import tempfile


def scratch_dir(test, prefix):
    path = tempfile.mkdtemp(prefix=prefix)
    test.addCleanup(shutil.rmtree, path, ignore_errors=True)
    return path
