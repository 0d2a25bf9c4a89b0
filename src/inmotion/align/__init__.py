"""inmotion.align"""
