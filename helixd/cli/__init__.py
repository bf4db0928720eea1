"""helixd/cli"""
