"""Plant and controller in one process, no bus: the in-process runner and its compiled loop
(campaigns, fast runs)."""
