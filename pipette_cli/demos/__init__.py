"""Demonstrations: scripted experts, keyboard teleoperation, the HDF5 recorder."""
