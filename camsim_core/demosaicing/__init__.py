"""Demosaicing (chapter section 4.1). [stub: being written for issue 3]"""


def demosaic(image, method="bilinear", **options):
    raise NotImplementedError("demosaic is being written (issue 3)")
