"""helixd.link"""
