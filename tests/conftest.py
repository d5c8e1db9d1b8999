"""Test-session set-up shared by every test module."""

import signal

# A job started in the background by a non-interactive shell (``cmd &``, some CI runners)
# inherits SIGINT ignored, and Python then keeps it ignored: the resume tests' interrupts
# (mitsar.io.work_folder's test hook sends the process SIGINT, tests/test_campaign.py sends
# it to a campaign) would then do nothing. Ctrl-C as a user presses it is what they test, so
# the session restores Python's own handler; subprocesses then start with the default one.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
