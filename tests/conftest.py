import os
import tempfile

# Tests never touch the user's cache: derivations, verdicts and builds go to one
# scratch directory shared by every process of this test session (the pytest-xdist
# workers compute the same path; the subprocesses the tests start inherit it).
# Every cache entry is keyed by its content and written to a temporary file that
# is then renamed, so concurrent workers (or sessions) cannot corrupt each other;
# anything else a test writes goes to its own tmp_path.
os.environ.setdefault("DERIVE_CACHE_DIR",
                      os.path.join(tempfile.gettempdir(), f"derive-test-cache-{os.getuid()}"))
os.makedirs(os.environ["DERIVE_CACHE_DIR"], exist_ok=True)
