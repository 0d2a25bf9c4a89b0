"""inmotion.estimation"""
