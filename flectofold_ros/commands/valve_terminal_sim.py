"""``valve_terminal_sim``: a simulated Modbus TCP valve terminal for hardware-in-the-loop runs.

``valve_terminal_sim --map config/modbus_terminal.yaml [--port 1502]`` serves the register
map's channels, each a simulated cushion circuit of a facade panel, on 127.0.0.1 (only this
host, unless ``--host`` says otherwise); the panel nodes drive it with ``-p hardware:=modbus``.
``msg_docs/modbus.md``.
"""

import argparse
import asyncio
import sys

USAGE_NAME = 'valve_terminal_sim'


def _forced(text):
    try:
        address, count = (int(part, 0) for part in text.split('='))
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected ADDRESS=COUNT, got {text!r}') from None
    if not 0 <= address <= 65535 or not -32768 <= count <= 65535:
        raise argparse.ArgumentTypeError(f'{text!r}: address or count out of range')
    return address, count


def parse_arguments(argv):
    """Parse the command line into an ``argparse.Namespace``."""
    parser = argparse.ArgumentParser(prog=USAGE_NAME, description=__doc__.split('\n')[0])
    parser.add_argument('--map', required=True, help='register map YAML (msg_docs/modbus.md)')
    parser.add_argument('--host', default='127.0.0.1',
                        help='address to listen on (default 127.0.0.1: this host only)')
    parser.add_argument('--port', type=int, default=1502,
                        help='TCP port (default 1502; 0: a free one, printed at start)')
    parser.add_argument('--facade', default='',
                        help='facade YAML whose panels the channels are (default: the '
                             'embedded demonstrator)')
    parser.add_argument('--panels', default='',
                        help='comma-separated panel ids, one per channel (default: the '
                             "facade's first ones)")
    parser.add_argument('--seed', type=int, default=0, help='sensor noise seed')
    parser.add_argument('--response-delay-s', type=float, default=0.0,
                        help='every reply waits this long: a slow terminal (tests)')
    parser.add_argument('--force-input', type=_forced, action='append', default=[],
                        metavar='ADDRESS=COUNT',
                        help='hold an input register at a raw count (a broken sensor)')
    options = parser.parse_args(argv)
    if not 0 <= options.port <= 65535:
        parser.error(f'--port must be in [0, 65535], got {options.port}')
    if not 0.0 <= options.response_delay_s <= 60.0:
        parser.error('--response-delay-s must be in [0, 60] s')
    return options


def main(args=None):
    """Run the terminal until SIGINT or SIGTERM; exit 2 with one line on bad input."""
    from flectofold_ros.runtime.runner import run_command
    argv = sys.argv[1:] if args is None else list(args)[1:]

    def body(stop):
        try:
            options = parse_arguments(argv)
        except SystemExit as leaving:  # argparse: its message is printed already
            return leaving.code
        import logging
        # pymodbus' own warnings (a port in use, a dropped client) would add lines to the
        # one this program prints; its errors (a request for another unit id) stay.
        logging.getLogger('pymodbus').setLevel(logging.ERROR)
        from flectofold_model.facade import DEFAULT_FACADE, load_facade
        from flectofold_ros.hardware.register_map import load_register_map
        from flectofold_ros.hardware.terminal_sim import serve, SimulatedTerminal, \
            terminal_plant
        register_map = load_register_map(options.map)
        ids = [p.strip() for p in options.panels.split(',') if p.strip()] or None
        plant = terminal_plant(register_map, load_facade(options.facade or DEFAULT_FACADE),
                               ids, seed=options.seed)
        terminal = SimulatedTerminal(register_map, plant, options.response_delay_s,
                                     dict(options.force_input))

        def started(host, port):
            print(f'{USAGE_NAME}: serving {register_map.count} channel(s) of unit '
                  f'{register_map.unit_id} on {host}:{port}', flush=True)
            stop.running()

        asyncio.run(serve(terminal, options.host, options.port, started,
                          lambda: stop.requested))
        return 0

    return run_command(USAGE_NAME, body, (OSError,))


if __name__ == '__main__':
    sys.exit(main())
