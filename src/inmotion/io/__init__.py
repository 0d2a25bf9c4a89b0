"""inmotion.io"""
