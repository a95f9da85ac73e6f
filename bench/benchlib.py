"""Helpers shared by the bench scripts."""
import json
import subprocess
import sys


def run_json(cmd):
    """Runs a vdbscatter command with --json and returns its report; exits on failure."""
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {p.stderr}")
    return json.loads(p.stdout)
