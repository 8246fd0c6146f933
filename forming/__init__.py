"""forming: process simulation of press-formed composite sandwich panels."""

__version__ = "0.1.0"
