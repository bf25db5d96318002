"""Shared fixtures: every test that takes ``impl`` runs once per implementation of the method.

``roadpreview.native`` exposes the C++ core's stage functions with the call shapes of ``roadpreview.reference``
and returns objects with the same attribute names.

Property tests draw the same examples on every run (hypothesis profile "repeatable", the default here) so that
a green suite stays green; ``HYPOTHESIS_PROFILE=explore`` draws new ones, to hunt for failures — keep what
they find as an ``@example``.
"""

import os

import pytest
from hypothesis import settings

import roadpreview.native
import roadpreview.reference

# No deadline: a test's time is no assertion here (benchmarks measure speed), and a busy 2-core machine once took
# 279 ms over hypothesis' default 200 ms for an example that runs in 190 ms.
settings.register_profile("repeatable", derandomize=True, deadline=None)
settings.register_profile("explore", derandomize=False, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

IMPLEMENTATIONS = [("reference", roadpreview.reference), ("cpp", roadpreview.native)]


# Session scope: hypothesis refuses function-scoped fixtures in @given tests.
@pytest.fixture(scope="session", params=[module for _, module in IMPLEMENTATIONS],
                ids=[name for name, _ in IMPLEMENTATIONS])
def impl(request):
    return request.param
