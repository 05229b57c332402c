"""The two tiers: ``pytest -m "not slow"`` (minutes, compile time bounded) and the full suite
(``pytest``, which CI runs). The fast tier must keep at least one test of every test file, so that
each file's subject is still exercised when the slow tests are left out."""


def test_every_test_file_keeps_a_fast_test(request):
    """Among the tests collected in this session, every file has one not marked ``slow``. In the
    full suite that covers every file; under ``-m "not slow"`` a file whose tests were all marked
    slow is not collected at all, so the check needs the full run (CI's) to see it."""
    items = request.session.items
    files = {item.path.name for item in items}
    fast = {item.path.name for item in items if item.get_closest_marker("slow") is None}
    assert request.node.path.name in fast  # this test itself: the session's items are visible here
    assert not files - fast, f"test files whose every test is marked slow: {sorted(files - fast)}"
