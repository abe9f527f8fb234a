"""The live view: a run served to Foxglove over its WebSocket protocol while it runs.

:mod:`hil.live.scene` draws the turbine from its presets and places it from the plant's
truth (:class:`~bus_schemas.messages.PlantState`); :mod:`hil.live.server` is the read-only
Foxglove WebSocket server with the run log's channels; :mod:`hil.live.node` is the process
``fowt run --live`` starts beside the recorder (it subscribes on the run's bus with the run's
key); :mod:`hil.live.replay` serves a recorded run log (``fowt view``). docs/guide/live-view.md.
"""
