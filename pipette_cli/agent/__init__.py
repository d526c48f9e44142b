"""``pipette agent``: natural-language requests -> exact ``pipette`` commands (paper appendix B)."""
