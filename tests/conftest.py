"""Settings of the whole test session."""

from __future__ import annotations

import signal

# Tests that press Ctrl-C on a child nudge (SIGINT) need the child to take it. A shell that starts
# a job in the background without job control (`pytest &` in a script) ignores SIGINT for it, and
# every process started from it would inherit that and never be interrupted; a handler here is
# reset to the default in each child, so they take Ctrl-C however the suite was started.
signal.signal(signal.SIGINT, signal.default_int_handler)
