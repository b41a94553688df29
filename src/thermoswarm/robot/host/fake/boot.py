# Start the built robot on MicroPython's unix port in closed loop with a host.
import machine

machine.link()
import main  # noqa: E402

main.run()
