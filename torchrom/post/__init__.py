"""After the analysis: mode shapes, the flutter mode and LCO motion as files for viewers
(:mod:`.viewers`: VTU, XDMF, OP2) and as pictures (:mod:`.pictures`: PNG, GIF), from the frames
of :mod:`.motions`."""
