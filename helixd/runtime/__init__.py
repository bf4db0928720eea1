"""helixd/runtime"""
