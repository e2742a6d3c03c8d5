"""The application: command line, runs and studies, outputs and figures."""
