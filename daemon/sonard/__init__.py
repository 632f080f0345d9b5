"""sonard: the acquisition daemon for the Nomad 200 sonar ring.

Modules, one job each: :mod:`~sonard.plan` (YAML plans, validation, SI conversion) and
:mod:`~sonard.plan_steps` (the motion steps a plan lists),
:mod:`~sonard.link` (bytes per poll, line time), :mod:`~sonard.ring` (the sensors table),
:mod:`~sonard.tagging` (new firings -> pose-tagged SI readings),
:mod:`~sonard.writer_thread` (the queue in front of the log writer),
:mod:`~sonard.acquisition` (the serial loop, pacing, fault recovery),
:mod:`~sonard.recording` (replies -> queued readings, poses and events),
:mod:`~sonard.link_faults` (a lost link, reconnecting with backoff),
:mod:`~sonard.motion` (closed-loop moves), :mod:`~sonard.steps` and
:mod:`~sonard.wallfollow` (resumable plan steps), :mod:`~sonard.notify` (sd_notify),
:mod:`~sonard.daemon` (one run from start to exit) and :mod:`~sonard.cli` (``sonard``).
"""
