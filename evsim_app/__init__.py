"""The application: the `evsim` command line, `evsim info`, figures and animations, and the demo's background
compiler."""
