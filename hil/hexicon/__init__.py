"""The Hexicon twin-turbine platform family: model, nodes, review and identification."""
