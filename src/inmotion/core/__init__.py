"""Math and physics: rotations, Earth model, SINS mechanization, dead reckoning."""
