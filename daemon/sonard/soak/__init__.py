"""Soak test of sonard against the emulator: real processes, a pty, a fault a minute.

``scripts/soak DURATION`` (``python -m sonard.soak``) runs :mod:`sonard.soak.emulator` (the
emulated Nomad 200 on a pseudo-terminal, injecting garbled, dropped and stalled replies and
unplugging the port in turn) and one long sonard on it, samples sonard's RSS and open file
descriptors, then kills further sonards at random moments to check crash finalisation.
:mod:`sonard.soak.processes` starts and samples those processes; :mod:`sonard.soak.accounting`
holds the checks: every firing in the emulator's trace is in the log or inside a logged
outage, and resource slopes per hour.
"""
