"""helixd/commands"""
