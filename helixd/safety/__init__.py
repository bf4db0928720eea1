"""helixd.safety"""
