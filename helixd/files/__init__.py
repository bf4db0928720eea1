"""helixd/files"""
