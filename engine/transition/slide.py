"""Slides: turning a blocked step into motion along the obstacle.

Placeholder until the transition module lands; see slide_sphere below.
"""
