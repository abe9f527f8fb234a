"""Scenarios of the Hexicon H3 platform family (hil.hexicon), apart from the single-turbine ones."""
