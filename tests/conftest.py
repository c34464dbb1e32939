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


# The tests that, with a cold cache, are the first to pay for a long build (a derivation of
# a large model, a compile of every generated file or of a high-order Taylor integrator),
# measured with `--durations` from an empty cache.  They are run first: the tests that need
# the same build come later and find it in the cache, and no build of a minute starts at
# the end of the run while the other worker has nothing left to do.  (pytest-xdist hands
# tests out in collection order; --dist loadgroup in tests/run.sh sends the xdist_group
# files, which share one build each, out first.)
FIRST = (
    "tests/codegen/test_generate_and_compile.py::test_generated_c_compiles_warning_free",
    "tests/runtime/test_precision_ladder.py::test_values_cross_exactly",
    "tests/scene/test_run_scene.py::test_scene_edge_cases_get_a_clean_answer",
    "tests/measurement/test_chaotic_reference.py::test_long_double_taylor_follows_the_reference_to_t_10",
    "tests/sweep/test_sweep.py::test_mirror_images_equal_computing_every_chunk",
    "tests/runtime/test_taylor.py::test_user_models_agree_with_dop853",
    "tests/runtime/test_taylor_lanes.py::test_the_number_of_lanes_changes_no_result",
    "tests/scene/test_accuracy_targets.py::test_a_missed_target_is_one_line_and_exit_3",
    "tests/verification/test_errata.py::test_the_errata_found_are_the_errata_recorded",
    "tests/codegen/test_generate_and_compile.py::test_generated_is_current",
    "tests/runtime/test_ensemble.py::test_taylor_ensemble_is_simulate_trajectory_by_trajectory",
    "tests/codegen/test_generate_and_compile.py::test_spec_is_driven_by_the_derivation_not_the_name",
    "tests/derivation/test_equations_against_mechanics.py::test_mechanics_references_agree_with_the_cartesian_chain",
    "tests/model/test_user_models.py::test_a_user_models_c_is_clean_under_werror",
)


def pytest_configure(config):
    # pytest-xdist registers its marker; without the plugin (-p no:xdist, -n 0 runs) the
    # files that name a group must still pass --strict-markers
    config.addinivalue_line("markers", "xdist_group(name): the tests of one group run on one "
                                       "pytest-xdist worker (--dist loadgroup)")


def pytest_collection_modifyitems(config, items):
    def rank(item):
        base = item.nodeid.split("[", 1)[0]
        return FIRST.index(base) if base in FIRST else len(FIRST)
    items.sort(key=rank)        # stable: the rest keep their order
