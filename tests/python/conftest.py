"""Shared fixtures: every test that takes ``impl`` runs once per implementation of the method.

``roadpreview.native`` exposes the C++ core's stage functions with the call shapes of ``roadpreview.reference``
and returns objects with the same attribute names.
"""

import pytest

import roadpreview.native
import roadpreview.reference

IMPLEMENTATIONS = [("reference", roadpreview.reference), ("cpp", roadpreview.native)]


# Session scope: hypothesis refuses function-scoped fixtures in @given tests.
@pytest.fixture(scope="session", params=[module for _, module in IMPLEMENTATIONS],
                ids=[name for name, _ in IMPLEMENTATIONS])
def impl(request):
    return request.param
