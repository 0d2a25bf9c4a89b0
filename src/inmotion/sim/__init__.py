"""inmotion.sim"""
