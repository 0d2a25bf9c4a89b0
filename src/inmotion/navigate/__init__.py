"""inmotion.navigate"""
