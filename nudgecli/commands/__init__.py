"""The ``nudge`` commands, grouped by job; :mod:`nudgecli.cli` registers each module's
``COMMANDS`` on its ``main`` group. Like the group, they only parse, call and print; the heavy
imports stay inside the commands, so ``nudge --help`` stays fast."""
