"""helixd/mav"""
