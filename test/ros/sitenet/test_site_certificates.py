"""site_certificates: the site CA, host certificates and Fast DDS profiles, and their bounds."""

import ipaddress
import os
from pathlib import Path
import re
import shutil
import stat
import subprocess
from xml.etree import ElementTree

from cryptography import x509
from cryptography.hazmat.primitives.asymmetric import rsa
from cryptography.x509.oid import ExtendedKeyUsageOID
import pytest

from flectofold_ros.commands import site_certificates
from flectofold_ros.sitenet import certificates, fastdds_profile
from flectofold_ros.sitenet.certificates import SiteError

BITS = 2048  # the least size offered, for speed
NS = {'p': fastdds_profile.NAMESPACE}


@pytest.fixture(scope='module')
def site(tmp_path_factory):
    """Make a site CA with one host, ``panels-1`` at 10.213.60.1 dialling 10.213.60.2:45100."""
    directory = tmp_path_factory.mktemp('site')
    assert site_certificates.main(['site_certificates', 'init', str(directory),
                                   '--key-bits', str(BITS)]) == 0
    assert site_certificates.main(['site_certificates', 'host', str(directory), 'panels-1',
                                   '--ip', '10.213.60.1', '--peer', '10.213.60.2:45100',
                                   '--listen-port', '45100',
                                   '--key-bits', str(BITS)]) == 0
    return directory


def _load(path):
    return x509.load_pem_x509_certificates(Path(path).read_bytes())


def test_the_site_ca_signs_hosts_and_nothing_below_them(site):
    (ca,) = _load(site / certificates.CA_CERT)
    constraints = ca.extensions.get_extension_for_class(x509.BasicConstraints).value
    assert constraints.ca and constraints.path_length == 0
    usage = ca.extensions.get_extension_for_class(x509.KeyUsage).value
    assert usage.key_cert_sign and usage.crl_sign and not usage.digital_signature
    assert isinstance(ca.public_key(), rsa.RSAPublicKey) and ca.public_key().key_size == BITS
    days = (ca.not_valid_after_utc - ca.not_valid_before_utc).days
    assert certificates.CA_DAYS <= days <= certificates.CA_DAYS + 1


def test_a_host_certificate_names_the_host_for_both_ends_of_tls(site):
    host, ca = _load(site / 'panels-1.pem')  # the chain: the host's, then the CA's
    assert ca == _load(site / certificates.CA_CERT)[0]
    host.verify_directly_issued_by(ca)
    names = host.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert names.get_values_for_type(x509.DNSName) == ['panels-1']
    assert names.get_values_for_type(x509.IPAddress) == [ipaddress.ip_address('10.213.60.1')]
    purposes = host.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
    assert set(purposes) == {ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH}
    assert not host.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    assert host.not_valid_after_utc <= ca.not_valid_after_utc


@pytest.mark.skipif(shutil.which('openssl') is None, reason='needs the openssl command')
def test_openssl_verifies_a_host_against_the_site_ca_and_not_a_foreign_one(site, tmp_path):
    ok = subprocess.run(['openssl', 'verify', '-CAfile', str(site / certificates.CA_CERT),
                         str(site / 'panels-1.pem')], capture_output=True, text=True)
    assert ok.returncode == 0 and ': OK' in ok.stdout, ok.stdout + ok.stderr
    certificates.make_authority(tmp_path, bits=BITS)
    foreign = subprocess.run(['openssl', 'verify', '-CAfile',
                              str(tmp_path / certificates.CA_CERT), str(site / 'panels-1.pem')],
                             capture_output=True, text=True)
    assert foreign.returncode != 0


def test_keys_are_written_for_the_owner_alone_whatever_the_umask(tmp_path):
    old = os.umask(0)
    try:
        certificates.make_authority(tmp_path, bits=BITS)
        certificates.make_host(tmp_path, 'h1', '10.0.0.1', bits=BITS)
    finally:
        os.umask(old)
    for name in (certificates.CA_KEY, 'h1.key'):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o600


def test_existing_keys_are_kept_unless_forced(tmp_path):
    certificates.make_authority(tmp_path, bits=BITS)
    before = (tmp_path / certificates.CA_KEY).read_bytes()
    with pytest.raises(SiteError, match='never overwritten without --force'):
        certificates.make_authority(tmp_path, bits=BITS)
    assert (tmp_path / certificates.CA_KEY).read_bytes() == before
    certificates.make_host(tmp_path, 'h1', '10.0.0.1', bits=BITS)
    with pytest.raises(SiteError, match='never overwritten without --force'):
        certificates.make_host(tmp_path, 'h1', '10.0.0.1', bits=BITS)
    host_key = (tmp_path / 'h1.key').read_bytes()
    certificates.make_host(tmp_path, 'h1', '10.0.0.1', bits=BITS, force=True)
    assert (tmp_path / 'h1.key').read_bytes() != host_key
    certificates.make_authority(tmp_path, bits=BITS, force=True)
    assert (tmp_path / certificates.CA_KEY).read_bytes() != before


def test_a_host_without_a_site_ca_is_refused_naming_init(tmp_path):
    with pytest.raises(SiteError, match='make the site CA first'):
        certificates.make_host(tmp_path, 'h1', '10.0.0.1', bits=BITS)
    assert not (tmp_path / 'h1.key').exists()


@pytest.mark.parametrize('name', ['h', 'a' * 63, 'panel-07', 'panels.site-1.example'])
def test_host_names_at_the_bounds_are_taken(name):
    assert certificates.check_hostname(name) == name


@pytest.mark.parametrize('name', ['', 'a' * 64, 'panel_07', '-a', 'a-', 'a..b', 'a b', 7])
def test_host_names_beyond_the_bounds_are_refused(name):
    with pytest.raises(SiteError, match='is not a host name'):
        certificates.check_hostname(name)


@pytest.mark.parametrize('address', ['10.0.0.1', '255.255.255.254', '1.0.0.0'])
def test_host_addresses_are_taken(address):
    assert certificates.check_ipv4(address) == address


@pytest.mark.parametrize('address, reason', [
    ('256.0.0.1', 'not an IPv4'), ('10.0.0', 'not an IPv4'), ('fe80::1', 'not an IPv4'),
    ('panel-1', 'not an IPv4'), ('0.0.0.0', 'not a host address'),
    ('224.0.0.1', 'not a host address'), ('255.255.255.255', 'not a host address')])
def test_bad_addresses_are_refused(address, reason):
    with pytest.raises(SiteError, match=reason):
        certificates.check_ipv4(address)


@pytest.mark.parametrize('port', [1, '1', 65535, '65535'])
def test_ports_at_the_bounds_are_taken(port):
    assert certificates.check_port(port) == int(port)


@pytest.mark.parametrize('port, reason', [(0, r'\[1, 65535\]'), ('0', r'\[1, 65535\]'),
                                          (65536, r'\[1, 65535\]'), ('-1', 'whole number'),
                                          ('4510x', 'whole number'), (True, 'whole number')])
def test_ports_beyond_the_bounds_are_refused(port, reason):
    with pytest.raises(SiteError, match=reason):
        certificates.check_port(port)


@pytest.mark.parametrize('days', [1, 3650])
def test_validity_at_the_bounds_is_taken(days):
    assert certificates.check_days(days) == days


@pytest.mark.parametrize('days', [0, 3651, 1.5])
def test_validity_beyond_the_bounds_is_refused(days):
    with pytest.raises(SiteError, match=r'\[1, 3650\]'):
        certificates.check_days(days)


def test_key_sizes_other_than_2048_or_3072_are_refused(tmp_path):
    with pytest.raises(SiteError, match='key size'):
        certificates.make_authority(tmp_path, bits=1024)


def _profile(site, name='panels-1'):
    return ElementTree.parse(site / f'{name}.xml').getroot()


def test_the_profile_holds_the_transport_to_tls_on_the_host_address_alone(site):
    root = _profile(site)
    (descriptor,) = root.findall('p:transport_descriptors/p:transport_descriptor', NS)
    assert descriptor.findtext('p:type', namespaces=NS) == 'TCPv4'
    assert [a.text for a in descriptor.findall('p:interfaceWhiteList/p:address', NS)] == \
        ['10.213.60.1']
    assert descriptor.findtext('p:listening_ports/p:port', namespaces=NS) == '45100'
    # without it the two hosts of a trial never matched (msg_docs/security.md)
    assert descriptor.findtext('p:wan_addr', namespaces=NS) == '10.213.60.1'
    tls = descriptor.find('p:tls', NS)
    assert tls.findtext('p:private_key_file', namespaces=NS) == str(site / 'panels-1.key')
    assert tls.findtext('p:cert_chain_file', namespaces=NS) == str(site / 'panels-1.pem')
    assert tls.findtext('p:verify_file', namespaces=NS) == str(site / certificates.CA_CERT)
    assert [v.text for v in tls.findall('p:verify_mode/p:verify', NS)] == \
        ['VERIFY_PEER', 'VERIFY_FAIL_IF_NO_PEER_CERT']
    (participant,) = root.findall('p:participant', NS)
    assert participant.get('is_default_profile') == 'true'
    rtps = participant.find('p:rtps', NS)
    assert rtps.findtext('p:useBuiltinTransports', namespaces=NS) == 'false'
    assert rtps.findtext('p:userTransports/p:transport_id', namespaces=NS) == \
        descriptor.findtext('p:transport_id', namespaces=NS)
    peers = [(locator.findtext('p:tcpv4/p:address', namespaces=NS),
              locator.findtext('p:tcpv4/p:physical_port', namespaces=NS))
             for locator in rtps.findall('p:builtin/p:initialPeersList/p:locator', NS)]
    assert peers == [('10.213.60.2', '45100')]
    assert fastdds_profile.check_profile(site / 'panels-1.xml') == site / 'panels-1.xml'


def test_a_host_that_only_dials_lists_no_port_and_needs_a_peer(site):
    text = fastdds_profile.host_profile(site, 'panels-1', '10.213.60.1', None,
                                        [('10.213.60.2', 45100)])
    assert 'listening_ports' not in text and '10.213.60.2' in text
    with pytest.raises(SiteError, match='at least one --peer'):
        fastdds_profile.host_profile(site, 'panels-1', '10.213.60.1', None, [])


@pytest.mark.parametrize('peer, reason', [
    ('10.0.0.2', 'A.B.C.D:PORT'), ('10.0.0.2:0', r'\[1, 65535\]'),
    ('10.0.0.2:65536', r'\[1, 65535\]'), ('10.0.0:45100', 'not an IPv4'),
    ('[::1]:45100', 'A.B.C.D:PORT'), ('10.0.0.2:x-45101', 'whole number')])
def test_bad_peers_are_refused(peer, reason):
    with pytest.raises(SiteError, match=reason):
        fastdds_profile.parse_peer(peer)


def test_the_host_itself_or_a_peer_twice_is_refused(site):
    with pytest.raises(SiteError, match='this host itself'):
        fastdds_profile.host_profile(site, 'h', '10.0.0.1', 45100, [('10.0.0.1', 45100)])
    with pytest.raises(SiteError, match='named twice'):
        fastdds_profile.host_profile(site, 'h', '10.0.0.1', 45100,
                                     [('10.0.0.2', 45100), ('10.0.0.2', 45100)])


@pytest.mark.parametrize('arguments, message', [
    (['--ip', '10.0.0.256'], 'not an IPv4'), (['--ip', '10.0.0.3', '--listen-port', '0'],
                                              r'\[1, 65535\]'),
    (['--ip', '10.0.0.3', '--listen-port', '65536'], r'\[1, 65535\]'),
    (['--ip', '10.0.0.3', '--peer', '10.0.0.4:70000'], r'\[1, 65535\]')])
def test_the_command_refuses_bad_input_with_exit_2_and_makes_no_key(
        site, capsys, arguments, message):
    code = site_certificates.main(['site_certificates', 'host', str(site), 'other', *arguments,
                                   '--key-bits', str(BITS)])
    assert code == 2
    assert re.search(message, capsys.readouterr().err)
    assert not (site / 'other.key').exists()


def test_the_command_refuses_a_name_that_is_no_host_name(site, capsys):
    assert site_certificates.main(['site_certificates', 'host', str(site), 'panel_1', '--ip',
                                   '10.0.0.3']) == 2
    assert 'is not a host name' in capsys.readouterr().err


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize('text, reason', [
    ('<profiles', 'not XML'),
    ('<other/>', 'not a Fast DDS <profiles>'),
    ('<profiles><participant profile_name="x"/></profiles>', 'is_default_profile'),
])
def test_a_profile_that_is_no_usable_fast_dds_profile_is_refused(tmp_path, text, reason):
    with pytest.raises(SiteError, match=reason):
        fastdds_profile.check_profile(_write(tmp_path / 'p.xml', text))


def test_a_missing_profile_or_a_tls_file_that_is_not_there_is_refused(site, tmp_path):
    with pytest.raises(SiteError, match='cannot be read'):
        fastdds_profile.check_profile(tmp_path / 'absent.xml')
    text = (site / 'panels-1.xml').read_text().replace(str(site / 'panels-1.key'),
                                                       str(tmp_path / 'gone.key'))
    with pytest.raises(SiteError, match='without TLS'):
        fastdds_profile.check_profile(_write(tmp_path / 'p.xml', text))


def test_the_site_environment_names_the_profile_and_drops_what_would_override_it(site):
    env = fastdds_profile.site_environment(site / 'panels-1.xml', {
        'ROS_STATIC_PEERS': '10.0.0.9', 'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4',
        'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'HOME': '/root'})
    assert env == {'HOME': '/root', 'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp',
                   'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET',
                   'FASTRTPS_DEFAULT_PROFILES_FILE': str(site / 'panels-1.xml'),
                   'FASTDDS_DEFAULT_PROFILES_FILE': str(site / 'panels-1.xml')}


def test_facade_refuses_a_site_profile_that_is_not_there_before_starting_anything(tmp_path,
                                                                                  capsys):
    from flectofold_ros.bringup import cli
    before = dict(os.environ)
    assert cli.main(['facade', '--site-profile', str(tmp_path / 'absent.xml')]) == 2
    assert 'cannot be read' in capsys.readouterr().err
    assert dict(os.environ) == before


def test_a_peer_range_names_each_port_of_a_host_up_to_64():
    assert fastdds_profile.parse_peer('10.0.0.2:45100') == [('10.0.0.2', 45100)]
    assert fastdds_profile.parse_peer('10.0.0.2:45100-45102') == [
        ('10.0.0.2', 45100), ('10.0.0.2', 45101), ('10.0.0.2', 45102)]
    assert len(fastdds_profile.parse_peer('10.0.0.2:45100-45163')) == 64
    for text in ('10.0.0.2:45100-45164', '10.0.0.2:45100-45099', '10.0.0.2:65535-65536'):
        with pytest.raises(SiteError):
            fastdds_profile.parse_peer(text)


def _ports(text):
    root = ElementTree.fromstring(text)
    listening = root.findtext('.//p:listening_ports/p:port', namespaces=NS)
    dialled = [(locator.findtext('p:tcpv4/p:address', namespaces=NS),
                int(locator.findtext('p:tcpv4/p:physical_port', namespaces=NS)))
               for locator in root.findall('.//p:initialPeersList/p:locator', NS)]
    return int(listening), dialled


def test_each_process_of_a_host_listens_on_its_own_port_and_dials_the_others(site):
    path = site / 'panels-1.xml'
    assert _ports(fastdds_profile.process_profile(path, 0, 1)) == \
        (45100, [('10.213.60.2', 45100)])
    for index in range(3):
        port, dialled = _ports(fastdds_profile.process_profile(path, index, 3))
        assert port == 45100 + index
        assert dialled == [('10.213.60.2', 45100)] + [
            ('10.213.60.1', 45100 + k) for k in range(3) if k != index]
    text = fastdds_profile.process_profile(path, 1, 3)
    assert '<tls>' in text and 'VERIFY_FAIL_IF_NO_PEER_CERT' in text


@pytest.mark.parametrize('index, count, reason', [
    (0, 0, r'\[1, 64\]'), (0, 65, r'\[1, 64\]'), (3, 3, r'\[0, 2\]'), (-1, 3, r'\[0, 2\]')])
def test_process_counts_and_indices_beyond_the_bounds_are_refused(site, index, count, reason):
    with pytest.raises(SiteError, match=reason):
        fastdds_profile.process_profile(site / 'panels-1.xml', index, count)
    assert fastdds_profile.process_profile(site / 'panels-1.xml', 63, 64)


def test_ports_past_65535_for_the_processes_are_refused(site, tmp_path):
    text = fastdds_profile.host_profile(site, 'panels-1', '10.213.60.1', 65535)
    path = tmp_path / 'high.xml'
    path.write_text(text)
    assert fastdds_profile.process_profile(path, 0, 1)
    with pytest.raises(SiteError, match='pass 65535'):
        fastdds_profile.process_profile(path, 0, 2)


def test_only_a_panel_process_ignores_its_own_endpoints(site):
    path = site / 'panels-1.xml'
    assert fastdds_profile.IGNORE_LOCAL not in path.read_text()
    assert fastdds_profile.IGNORE_LOCAL not in fastdds_profile.process_profile(path, 0, 3)
    text = fastdds_profile.process_profile(path, 1, 3, panel_process=True)
    root = ElementTree.fromstring(text)
    (item,) = root.findall('.//p:rtps/p:propertiesPolicy/p:properties/p:property', NS)
    assert (item.findtext('p:name', namespaces=NS), item.findtext('p:value', namespaces=NS)) \
        == (fastdds_profile.IGNORE_LOCAL, 'true')


def test_a_profile_not_made_by_site_certificates_has_no_process_ports(site, tmp_path):
    assert fastdds_profile.listening_port(site / 'panels-1.xml') == 45100
    text = fastdds_profile.host_profile(site, 'panels-1', '10.213.60.1', None,
                                        [('10.213.60.2', 45100)])
    path = _write(tmp_path / 'dialling.xml', text)
    with pytest.raises(SiteError, match='not one listening port'):
        fastdds_profile.listening_port(path)
    with pytest.raises(SiteError, match='not one listening port'):
        fastdds_profile.process_profile(path, 0, 1)


def test_the_default_port_is_below_the_ephemeral_range(tmp_path):
    certificates.make_authority(tmp_path, bits=BITS)
    assert site_certificates.main(['site_certificates', 'host', str(tmp_path), 'h1', '--ip',
                                   '10.0.0.1', '--peer', '10.0.0.2:24100',
                                   '--key-bits', str(BITS)]) == 0
    assert fastdds_profile.listening_port(tmp_path / 'h1.xml') == \
        fastdds_profile.DEFAULT_LISTEN_PORT < 32768


def test_facade_refuses_more_processes_than_a_host_profile_gives_ports_for(site, capsys):
    from flectofold_ros.bringup import cli
    before = dict(os.environ)
    code = cli.main(['facade', '--panel-processes', '64', '--site-profile',
                     str(site / 'panels-1.xml')])
    assert code == 2
    assert r'[1, 64], got 65' in capsys.readouterr().err
    assert dict(os.environ) == before
