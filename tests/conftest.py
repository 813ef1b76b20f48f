import os

# MAVLink 2 framing for every pymavlink import in the test process (must precede `import pymavlink.mavutil`).
os.environ.setdefault("MAVLINK20", "1")
