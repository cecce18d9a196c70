"""Image quality metrics: CIELAB, S-CIELAB, block comparison (chapter 4.3). [stub: issue 4]"""
