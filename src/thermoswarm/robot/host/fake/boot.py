# Start the built robot on MicroPython's unix port in closed loop with a host.
import machine

machine.link()
import main  # noqa: E402

try:
    main.run()
finally:
    machine._sleep(0)  # hand the host the last duties (the motors' state at the end)
