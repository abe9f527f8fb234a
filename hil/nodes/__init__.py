"""The bench's processes on the bus: plant, controller, recorder and fuzzer nodes, the Zenoh and
CAN transports, the router, real-time pacing and timing."""
