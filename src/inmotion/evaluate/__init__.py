"""inmotion.evaluate"""
