"""Synthetic stereo rig: rendered scenes and chessboards with exact truth, and the evaluator."""
