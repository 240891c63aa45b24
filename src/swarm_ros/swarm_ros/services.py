"""Calling a service whose request may be repeated, without losing the call to a lost response."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rclpy.client import Client
from rclpy.task import Future

RESEND_AFTER = 10.0
"""Seconds without an answer after which an idempotent request is sent again."""


def call_until_answered(
    client: Client,
    request: Any,  # a request of the client's (generated, untyped) service type
    wait: Callable[[Future, float], bool],
    timeout: float,
    *,
    sent: Future | None = None,
    resend_after: float = RESEND_AFTER,
) -> Any | None:
    """The response of ``client``'s service to ``request``, or None when ``timeout`` seconds pass without one.

    For idempotent services only: a request without an answer after ``resend_after`` seconds is sent again. A
    service is "ready" to a client once the server has matched the client's requests, which can be before the
    client has matched the server's responses, so on a loaded machine the first response can be lost.
    ``wait(future, seconds)`` waits up to ``seconds`` for ``future`` and says whether it is done (by spinning
    an executor, or on an event where another thread spins); ``sent``: the future of a request already sent.
    """
    deadline = time.monotonic() + timeout
    future = sent if sent is not None else client.call_async(request)
    while True:
        if wait(future, min(resend_after, max(0.0, deadline - time.monotonic()))):
            return future.result()
        client.remove_pending_request(future)
        if time.monotonic() >= deadline:
            return None
        future = client.call_async(request)
