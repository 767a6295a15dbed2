"""A host's Fast DDS XML profile for the site network: TCPv4 with mutual TLS, nothing else.

:func:`host_profile` writes the profile text, :func:`check_profile` checks a profile file
before any process is started on it. The profile makes every participant of a process that
loads it (``FASTRTPS_DEFAULT_PROFILES_FILE``) use one TCPv4 transport with TLS:

- ``<tls>``: the host's key, its certificate chain, the site CA as the only trusted CA
  (``verify_file``), ``VERIFY_PEER`` and ``VERIFY_FAIL_IF_NO_PEER_CERT`` (a peer without a
  certificate the site CA signed is refused, either way round), SSLv2/SSLv3/TLS 1.0/1.1 off;
- an interface allowlist of the host's site address, so the transport neither listens nor
  sends on any other interface;
- ``useBuiltinTransports`` false, so no UDPv4 or shared-memory transport stays open beside it;
- discovery without multicast: the initial peers are the other site hosts' TCP listening
  ports. A TCP port has one listener: a second process on the same profile finds it taken
  (Fast DDS logs "Error binding") and reaches only the processes it dials, so a host with
  several processes gives each its own port and has them dial each other
  (:func:`process_profile`; ``facade`` and the launch file do it);
- the panel process's 3 s lease (``fastdds_panel_process.xml``), which a user profile
  replaces; its ``fastdds.ignore_local_endpoints`` only in a panel process's profile
  (:func:`process_profile`), since the bringup's own process talks to itself (the sun's
  ``/clock`` to its monitor and coordinator).

Elements: Fast DDS 2.14 documentation, "TLS over TCP" (``fastdds/transport/tcp/tls``),
"XML transports" (``fastdds/xml_configuration/transports``) and "Interfaces allowlist"
(``fastdds/transport/whitelist``); ``msg_docs/security.md``.
"""

from pathlib import Path
from xml.etree import ElementTree
from xml.sax.saxutils import escape

from flectofold_ros.sitenet.certificates import (CA_CERT, check_hostname, check_ipv4,
                                                 check_port, host_files, SiteError)

#: Namespace of Fast DDS profiles.
NAMESPACE = 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'
TRANSPORT_ID = 'flectofold_site_tls'
PROFILE_NAME = 'flectofold_site_host'
#: TCP port a host listens on when not told: below Linux's default range of ephemeral
#: ports (``net.ipv4.ip_local_port_range``, 32768..60999), from which an outgoing connection
#: could already hold it; the facade's processes take it and the next ones.
DEFAULT_LISTEN_PORT = 24100
#: The panel process's property (``fastdds_panel_process.xml``).
IGNORE_LOCAL = 'fastdds.ignore_local_endpoints'
#: Participant lease and announcement period [s], as ``fastdds_panel_process.xml``.
LEASE_S, ANNOUNCEMENT_S = 3, 1


def parse_peer(text):
    """Return the ``(address, port)`` of a peer written ``A.B.C.D:PORT`` or ``A.B.C.D:P-Q``.

    ``P-Q`` names the ports of a host that runs several processes (one port each, from P).
    """
    if not isinstance(text, str) or text.count(':') != 1:
        raise SiteError(f'peer {text!r} is not written A.B.C.D:PORT or A.B.C.D:P-Q')
    address, ports = text.split(':')
    address = check_ipv4(address)
    first, _, last = ports.partition('-')
    first = check_port(first, f'peer {text} port')
    last = check_port(last, f'peer {text} last port') if last else first
    if not first <= last <= first + 63:
        raise SiteError(f'peer {text}: the last port must lie in [{first}, {first + 63}]')
    return [(address, port) for port in range(first, last + 1)]


def _locator(address, port):
    return (f'          <locator><tcpv4><address>{address}</address>'
            f'<physical_port>{port}</physical_port></tcpv4></locator>')


def host_profile(directory, name, ip, listen_port=DEFAULT_LISTEN_PORT, peers=()):
    """Return the Fast DDS XML profile of host ``name`` at ``ip`` (text).

    ``listen_port`` (1..65535, or None: the host only dials) is the TCP port it listens on,
    ``peers`` the ``(address, port)`` of the other hosts it dials for discovery. File paths in the
    profile are absolute, into ``directory``, where ``site_certificates`` keeps the files.
    """
    check_hostname(name)
    ip = check_ipv4(ip)
    if listen_port is not None:
        listen_port = check_port(listen_port, 'listen port')
    peers = [(check_ipv4(address), check_port(port, f'peer {address} port'))
             for address, port in peers]
    if (ip, listen_port) in peers:
        raise SiteError(f'peer {ip}:{listen_port} is this host itself')
    if len(set(peers)) != len(peers):
        raise SiteError('a peer is named twice')
    if listen_port is None and not peers:
        raise SiteError('a host that listens on no port must have at least one --peer')
    directory = Path(directory).resolve()
    key, chain = host_files(directory, name)
    listening = ('' if listen_port is None else
                 f'      <listening_ports><port>{listen_port}</port></listening_ports>\n')
    initial = ''
    if peers:
        initial = ('        <initialPeersList>\n' +
                   '\n'.join(_locator(address, port) for address, port in peers) +
                   '\n        </initialPeersList>\n')
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<!-- Fast DDS profile of site host {escape(name)} ({ip}), made by site_certificates:
     TCPv4 with mutual TLS against the site CA only, on {ip} only, no UDP or shared memory.
     Load it with FASTRTPS_DEFAULT_PROFILES_FILE (facade - -site-profile does);
     msg_docs/security.md. -->
<profiles xmlns="{NAMESPACE}">
  <transport_descriptors>
    <transport_descriptor>
      <transport_id>{TRANSPORT_ID}</transport_id>
      <type>TCPv4</type>
      <interfaceWhiteList><address>{ip}</address></interfaceWhiteList>
      <wan_addr>{ip}</wan_addr>
{listening}      <tls>
        <private_key_file>{escape(str(key))}</private_key_file>
        <cert_chain_file>{escape(str(chain))}</cert_chain_file>
        <verify_file>{escape(str(directory / CA_CERT))}</verify_file>
        <verify_mode>
          <verify>VERIFY_PEER</verify>
          <verify>VERIFY_FAIL_IF_NO_PEER_CERT</verify>
        </verify_mode>
        <options>
          <option>DEFAULT_WORKAROUNDS</option>
          <option>NO_SSLV2</option>
          <option>NO_SSLV3</option>
          <option>NO_TLSV1</option>
          <option>NO_TLSV1_1</option>
        </options>
      </tls>
    </transport_descriptor>
  </transport_descriptors>
  <participant profile_name="{PROFILE_NAME}" is_default_profile="true">
    <rtps>
      <userTransports><transport_id>{TRANSPORT_ID}</transport_id></userTransports>
      <useBuiltinTransports>false</useBuiltinTransports>
      <builtin>
        <discovery_config>
          <leaseDuration><sec>{LEASE_S}</sec></leaseDuration>
          <leaseAnnouncement><sec>{ANNOUNCEMENT_S}</sec></leaseAnnouncement>
        </discovery_config>
{initial}      </builtin>
    </rtps>
  </participant>
</profiles>
"""


#: ``<tls>`` elements that name a file Fast DDS reads.
TLS_FILES = ('private_key_file', 'rsa_private_key_file', 'cert_chain_file', 'verify_file',
             'tmp_dh_file')


def _local(tag):
    return tag.rsplit('}', 1)[-1]


def check_profile(path):
    """Check a Fast DDS profile file before a process starts on it; return its path, absolute.

    Refused (:class:`SiteError`, naming the reason): a missing or unreadable file, XML that
    does not parse, a root other than ``profiles`` (or ``dds`` around it), no participant
    profile marked ``is_default_profile="true"`` (rclpy takes only that one), and a ``<tls>``
    naming a file that is not there: the Fast DDS 2.14 library carries the message "Error
    configuring TLS, using TCP transport without security" for a TLS set-up that fails.
    """
    path = Path(path).expanduser()
    try:
        root = ElementTree.parse(path).getroot()
    except OSError as error:
        raise SiteError(f'site profile {path}: cannot be read: '
                        f'{error.strerror or error}') from None
    except ElementTree.ParseError as error:
        raise SiteError(f'site profile {path}: not XML: {error}') from None
    if _local(root.tag) == 'dds':
        root = next((child for child in root if _local(child.tag) == 'profiles'), root)
    if _local(root.tag) != 'profiles':
        raise SiteError(f'site profile {path}: the root is <{_local(root.tag)}>, not a Fast '
                        f'DDS <profiles>')
    defaults = [element for element in root.iter() if _local(element.tag) == 'participant'
                and element.get('is_default_profile', '').lower() == 'true']
    if not defaults:
        raise SiteError(f'site profile {path}: no <participant is_default_profile="true">: '
                        f'ROS nodes would not use it')
    for tls in (element for element in root.iter() if _local(element.tag) == 'tls'):
        for element in tls.iter():
            if _local(element.tag) in TLS_FILES:
                named = Path((element.text or '').strip())
                if not (named.is_absolute() and named.is_file()):
                    raise SiteError(f'site profile {path}: <{_local(element.tag)}> '
                                    f'{element.text!r} is not a file (an absolute path): '
                                    f'Fast DDS would fall back to TCP without TLS')
    return path.resolve()


#: Variables a process on a site profile gets, besides the profile's path.
SITE_ENVIRONMENT = {'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp',
                    'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET'}
#: Variables removed: rmw_fastrtps sets up transports of its own for static peers.
SITE_REMOVED = ('ROS_STATIC_PEERS', 'FASTDDS_BUILTIN_TRANSPORTS')


def site_environment(path, environ):
    """Return a copy of ``environ`` for processes on the site profile at ``path`` (checked).

    ``FASTRTPS_DEFAULT_PROFILES_FILE`` (Fast DDS 2.x) and ``FASTDDS_DEFAULT_PROFILES_FILE``
    (3.x) name the profile; Fast DDS is the RMW; discovery range ``SUBNET``, since under
    ``LOCALHOST``, and with ``ROS_STATIC_PEERS``, rmw_fastrtps sets transports of its own
    (``msg_docs/multi_host.md``); ``FASTDDS_BUILTIN_TRANSPORTS`` removed (the profile
    chooses the transports).
    """
    path = str(check_profile(path))
    env = {name: value for name, value in environ.items() if name not in SITE_REMOVED}
    env.update(SITE_ENVIRONMENT, FASTRTPS_DEFAULT_PROFILES_FILE=path,
               FASTDDS_DEFAULT_PROFILES_FILE=path)
    return env


def _find(root, name):
    return [element for element in root.iter() if _local(element.tag) == name]


def _port_and_address(root, path):
    """Return the listening port element and the allowlisted address of a host profile."""
    ports, addresses = _find(root, 'listening_ports'), _find(root, 'interfaceWhiteList')
    if len(ports) != 1 or len(addresses) != 1 or len(_find(ports[0], 'port')) != 1 or \
            len(_find(addresses[0], 'address')) != 1:
        raise SiteError(f'site profile {path}: not one listening port and one allowlisted '
                        f'address: make it with site_certificates host')
    return (_find(ports[0], 'port')[0],
            check_ipv4((_find(addresses[0], 'address')[0].text or '').strip()))


def listening_port(path):
    """Return the TCP port a host profile ``site_certificates`` made listens on."""
    check_profile(path)
    element, _ = _port_and_address(ElementTree.parse(path).getroot(), path)
    return check_port((element.text or '').strip(), 'listening port')


def process_profile(path, index, count, panel_process=False):
    """Return host profile ``path`` for process ``index`` of ``count`` on its host (text).

    A TCP port has one listener: process ``index`` listens on the host's port plus
    ``index`` and dials, besides the profile's peers, the host's other ``count - 1`` ports, so
    that every process of the host finds the others (a process never dials itself: tried, a
    site host that did lost its peer and once aborted). The other hosts reach process
    ``index`` only if their profiles list its port (``--peer IP:P-Q``). ``path`` must be a
    profile ``site_certificates`` made (one TCPv4 transport with a listening port and one
    allowlisted address). ``panel_process``: add ``fastdds.ignore_local_endpoints``, as
    ``fastdds_panel_process.xml`` does for a panel process (its endpoints never talk to each
    other; pairing them made starting 1,000 panels take minutes, ``msg_docs/panel_node.md``).
    """
    check_profile(path)
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= 64:
        raise SiteError(f'processes on one host must lie in [1, 64], got {count!r}')
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < count:
        raise SiteError(f'process index must lie in [0, {count - 1}], got {index!r}')
    ElementTree.register_namespace('', NAMESPACE)
    tree = ElementTree.parse(path)
    root = tree.getroot()
    port_element, ip = _port_and_address(root, path)
    base = check_port((port_element.text or '').strip(), 'listening port')
    if base + count - 1 > 65535:
        raise SiteError(f'site profile {path}: ports {base}..{base + count - 1} pass 65535')
    port_element.text = str(base + index)
    (builtin,) = _find(root, 'builtin')
    peers = _find(builtin, 'initialPeersList')
    if not peers:
        peers = [ElementTree.SubElement(builtin, f'{{{NAMESPACE}}}initialPeersList')]
    for other in range(count):
        if other != index:
            locator = ElementTree.SubElement(peers[0], f'{{{NAMESPACE}}}locator')
            tcp = ElementTree.SubElement(locator, f'{{{NAMESPACE}}}tcpv4')
            ElementTree.SubElement(tcp, f'{{{NAMESPACE}}}address').text = ip
            ElementTree.SubElement(tcp, f'{{{NAMESPACE}}}physical_port').text = str(base + other)
    if panel_process:
        (rtps,) = (element for element in _find(root, 'rtps') if builtin in list(element))
        policy = ElementTree.SubElement(rtps, f'{{{NAMESPACE}}}propertiesPolicy')
        properties = ElementTree.SubElement(policy, f'{{{NAMESPACE}}}properties')
        item = ElementTree.SubElement(properties, f'{{{NAMESPACE}}}property')
        ElementTree.SubElement(item, f'{{{NAMESPACE}}}name').text = IGNORE_LOCAL
        ElementTree.SubElement(item, f'{{{NAMESPACE}}}value').text = 'true'
    return ElementTree.tostring(root, encoding='unicode', xml_declaration=True)
