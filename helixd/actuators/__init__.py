"""helixd.actuators"""
