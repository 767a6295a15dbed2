"""Make a site network's CA and its hosts' certificates and Fast DDS profiles (mutual TLS).

``site_certificates init DIR``: the site CA (``DIR/site-ca.key``, 0600, and
``DIR/site-ca.pem``). ``site_certificates host DIR NAME --ip A.B.C.D [--listen-port P]
[--peer IP:PORT ...]``: host NAME's key (``DIR/NAME.key``, 0600), its certificate signed by
the site CA (``DIR/NAME.pem``, with the CA's after it) and its Fast DDS profile
(``DIR/NAME.xml``) for ``facade --site-profile``. Keys are never overwritten without
``--force``. Exit code 2 on bad input, naming it. Logic: :mod:`flectofold_ros.sitenet`; the
site-network guide: ``msg_docs/security.md``.
"""

import argparse
from pathlib import Path
import sys

from flectofold_ros.runtime.runner import run_command
from flectofold_ros.sitenet import certificates, fastdds_profile as profile


def parse_arguments(argv):
    parser = argparse.ArgumentParser(prog='site_certificates',
                                     description=__doc__.split('\n')[0])
    commands = parser.add_subparsers(dest='command', required=True)
    days_low, days_high = certificates.DAYS_RANGE
    init = commands.add_parser('init', help='make the site CA in DIR')
    init.add_argument('directory', metavar='DIR')
    init.add_argument('--days', type=int, default=certificates.CA_DAYS,
                      help=f'validity in days, in [{days_low}, {days_high}] '
                           f'(default {certificates.CA_DAYS})')
    host = commands.add_parser('host', help="make host NAME's key, certificate and profile")
    host.add_argument('directory', metavar='DIR', help='the site directory (with the CA)')
    host.add_argument('name', metavar='NAME', help='the host name (RFC 1123)')
    host.add_argument('--ip', required=True, metavar='A.B.C.D',
                      help="the host's address on the site network")
    host.add_argument('--listen-port', default=str(profile.DEFAULT_LISTEN_PORT), metavar='P',
                      help='TCP port it listens on, in [1, 65535] (default '
                           f'{profile.DEFAULT_LISTEN_PORT}); "none": it only dials its peers')
    host.add_argument('--peer', action='append', default=[], metavar='IP:PORT',
                      help='a host it dials for discovery (repeat for several); IP:P-Q: a '
                           'host with several processes, on ports P to Q (facade: one per '
                           'process, from its listen port)')
    host.add_argument('--days', type=int, default=certificates.HOST_DAYS,
                      help=f'validity in days, in [{days_low}, {days_high}], cut to the '
                           f"CA's end (default {certificates.HOST_DAYS})")
    for sub in (init, host):
        sub.add_argument('--key-bits', type=int, default=certificates.DEFAULT_KEY_BITS,
                         choices=certificates.KEY_BITS,
                         help=f'RSA key size (default {certificates.DEFAULT_KEY_BITS})')
        sub.add_argument('--force', action='store_true',
                         help='overwrite an existing key (and its certificate)')
    return parser.parse_args(argv)


def make(options):
    """Do what ``options`` ask; print what was written."""
    directory = Path(options.directory)
    if options.command == 'init':
        certificate = certificates.make_authority(directory, days=options.days,
                                                  bits=options.key_bits, force=options.force)
        print(f'site_certificates: site CA in {directory / certificates.CA_CERT} (key '
              f'{directory / certificates.CA_KEY}, mode 0600), valid until '
              f'{certificate.not_valid_after_utc:%Y-%m-%d}', flush=True)
        return 0
    port = None if options.listen_port == 'none' else options.listen_port
    peers = [peer for text in options.peer for peer in profile.parse_peer(text)]
    # the profile first: bad input is refused before any key is made
    text = profile.host_profile(directory, options.name, options.ip, port, peers)
    certificate = certificates.make_host(directory, options.name, options.ip, days=options.days,
                                         bits=options.key_bits, force=options.force)
    xml_path = directory / f'{options.name}.xml'
    xml_path.write_text(text)
    key_path, chain_path = certificates.host_files(directory, options.name)
    print(f'site_certificates: host {options.name} ({options.ip}): key {key_path} (mode '
          f'0600), certificate {chain_path} valid until '
          f'{certificate.not_valid_after_utc:%Y-%m-%d}, profile {xml_path}', flush=True)
    return 0


def main(args=None):
    """``site_certificates init DIR`` | ``site_certificates host DIR NAME --ip A.B.C.D ...``."""
    options = parse_arguments((sys.argv if args is None else args)[1:])
    return run_command('site_certificates', lambda stop: make(options))


if __name__ == '__main__':
    sys.exit(main())
