"""helixd/serve"""
