import os
import tempfile

# Tests never touch the user's cache: derivations and builds go to a scratch
# directory shared by this test session (derivations are cached inside it).
os.environ.setdefault("DERIVE_CACHE_DIR", os.path.join(tempfile.gettempdir(), "derive-test-cache"))
