"""inmotion.cli"""
