"""The site's certificate authority and its hosts' keys and certificates (X.509, RSA).

:func:`make_authority` makes a site CA (a self-signed RSA key pair that may sign host
certificates and nothing else below it: ``path_length=0``); :func:`make_host` makes a host's
key and a certificate the CA signs, naming the host by DNS name and IPv4 address
(subjectAltName) and good for both ends of a TLS connection (server and client
authentication), as Fast DDS's TCP transport needs: every participant may dial or be dialled.
Keys are RSA (the Fast DDS TLS transport was tried with RSA keys only), written PKCS#8 PEM
unencrypted with mode 0600, never over an existing key unless asked. Validity bounds:
:data:`CA_DAYS`, :data:`HOST_DAYS`. Sources: the ``cryptography`` X.509 tutorial
(https://cryptography.io/en/latest/x509/tutorial/), RFC 5280 for the extensions;
``msg_docs/security.md``.
"""

import datetime
import ipaddress
import os
from pathlib import Path
import re

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import rsa
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

#: RSA key sizes the command makes [bit]; 2048 is the least NIST SP 800-57 allows past 2030
#: for new keys only with 3072, so both are offered and 3072 is the default.
KEY_BITS = (2048, 3072)
DEFAULT_KEY_BITS = 3072
#: Validity of the site CA and of a host certificate [days]: at least a day, at most the CA's
#: 10 years (a host's certificate never outlives the CA that signs it, and is cut to the CA's
#: end when it would).
DAYS_RANGE = (1, 3650)
CA_DAYS, HOST_DAYS = 3650, 825
#: File names in the site directory.
CA_KEY, CA_CERT = 'site-ca.key', 'site-ca.pem'
#: A host name as RFC 1123 allows: labels of letters, digits and inner hyphens, 1..63 each.
HOSTNAME = re.compile(r'(?=.{1,253}$)([A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?)'
                      r'(\.[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?)*')
KEY_MODE = 0o600


class SiteError(ValueError):
    """A request the site tools refuse; the message names the input and the reason."""


def check_hostname(name):
    """Return ``name`` if it is an RFC 1123 host name (letters, digits, hyphens, dots)."""
    if not isinstance(name, str) or not HOSTNAME.fullmatch(name):
        raise SiteError(f'host name {name!r} is not a host name (RFC 1123: labels of letters, '
                        f'digits and inner hyphens, 1 to 63 characters, dot-separated)')
    return name


def check_ipv4(address):
    """Return ``address`` as text if it is a unicast IPv4 address A.B.C.D a host can have."""
    try:
        ip = ipaddress.IPv4Address(address)
    except (ipaddress.AddressValueError, TypeError, ValueError):
        raise SiteError(f'address {address!r} is not an IPv4 address A.B.C.D') from None
    if ip.is_unspecified or ip.is_multicast or ip == ipaddress.IPv4Address('255.255.255.255'):
        raise SiteError(f'address {address} is not a host address (unspecified, multicast '
                        f'or broadcast)')
    return str(ip)


def check_port(port, what='port'):
    """Return ``port`` as an int if it is a TCP port number in 1..65535 (an int or digits)."""
    if isinstance(port, str) and port.strip().isdigit():
        number = int(port)
    elif isinstance(port, int) and not isinstance(port, bool):
        number = port
    else:
        raise SiteError(f'{what} {port!r} is not a whole number')
    if not 1 <= number <= 65535:
        raise SiteError(f'{what} must lie in [1, 65535], got {number}')
    return number


def check_days(days, what='validity'):
    low, high = DAYS_RANGE
    if isinstance(days, bool) or not isinstance(days, int) or not low <= days <= high:
        raise SiteError(f'{what} must be a whole number of days in [{low}, {high}], got {days!r}')
    return days


def check_key_bits(bits):
    if bits not in KEY_BITS:
        raise SiteError(f'key size must be one of {", ".join(map(str, KEY_BITS))} bits, '
                        f'got {bits!r}')
    return bits


def _now():
    return datetime.datetime.now(datetime.timezone.utc)


def _new_key(bits):
    return rsa.generate_private_key(public_exponent=65537, key_size=check_key_bits(bits))


def _write_key(path, key, force):
    """Write ``key`` (PKCS#8 PEM) to ``path`` with mode 0600; refuse an existing file."""
    path = Path(path)
    if path.exists() and not force:
        raise SiteError(f'{path} exists: a key is never overwritten without --force')
    data = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())
    if path.exists():
        path.unlink()
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, KEY_MODE)
    with os.fdopen(descriptor, 'wb') as handle:
        handle.write(data)
    os.chmod(path, KEY_MODE)  # whatever the umask


def _write_certificate(path, certificate):
    Path(path).write_bytes(certificate.public_bytes(serialization.Encoding.PEM))


def make_authority(directory, name='flectofold site CA', days=CA_DAYS,
                   bits=DEFAULT_KEY_BITS, force=False):
    """Make the site CA in ``directory``: ``site-ca.key`` (0600) and ``site-ca.pem``.

    Self-signed, ``BasicConstraints(ca=True, path_length=0)`` (it signs host certificates,
    no intermediate CA), key usage certificate and CRL signing only, ``days`` valid
    (in :data:`DAYS_RANGE`). Return the certificate.
    """
    check_days(days, 'CA validity')
    directory = Path(directory)
    key_path = directory / CA_KEY
    if key_path.exists() and not force:
        raise SiteError(f'{key_path} exists: a site CA is never overwritten without --force')
    directory.mkdir(parents=True, exist_ok=True)
    key = _new_key(bits)
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
    now = _now()
    certificate = (
        x509.CertificateBuilder()
        .subject_name(subject).issuer_name(subject).public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=days))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(x509.KeyUsage(digital_signature=False, content_commitment=False,
                                     key_encipherment=False, data_encipherment=False,
                                     key_agreement=False, key_cert_sign=True, crl_sign=True,
                                     encipher_only=False, decipher_only=False), critical=True)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()),
                       critical=False)
        .sign(key, hashes.SHA256()))
    _write_key(key_path, key, force)
    _write_certificate(directory / CA_CERT, certificate)
    return certificate


def load_authority(directory):
    """Return the site CA's ``(key, certificate)`` from ``directory``; refuse a missing one."""
    directory = Path(directory)
    key_path, cert_path = directory / CA_KEY, directory / CA_CERT
    for path in (key_path, cert_path):
        if not path.is_file():
            raise SiteError(f'{path} is missing: make the site CA first '
                            f'(site_certificates init {directory})')
    try:
        key = serialization.load_pem_private_key(key_path.read_bytes(), password=None)
        certificate = x509.load_pem_x509_certificate(cert_path.read_bytes())
    except (ValueError, TypeError) as error:
        raise SiteError(f'the site CA in {directory} cannot be read: {error}') from None
    if not isinstance(key, rsa.RSAPrivateKey):
        raise SiteError(f'{key_path} is not an RSA key')
    if key.public_key().public_numbers() != certificate.public_key().public_numbers():
        raise SiteError(f'{key_path} is not the key of {cert_path}')
    return key, certificate


def host_files(directory, name):
    """Return ``(key, certificate chain)`` paths of host ``name`` in ``directory``."""
    directory = Path(directory)
    return directory / f'{name}.key', directory / f'{name}.pem'


def make_host(directory, name, ip, days=HOST_DAYS, bits=DEFAULT_KEY_BITS, force=False):
    """Make host ``name``'s key (``NAME.key``, 0600) and certificate (``NAME.pem``).

    The certificate is signed by the site CA in ``directory``, names the host as its common
    name and in subjectAltName (DNS ``name``, IP ``ip``), is not a CA, and is good for TLS
    server and client authentication. It is valid ``days`` (in :data:`DAYS_RANGE`), cut to
    the CA's end. ``NAME.pem`` holds the host's certificate then the CA's (the chain a TLS
    peer is shown). Return the host's certificate.
    """
    check_hostname(name)
    ip = check_ipv4(ip)
    check_days(days, 'host validity')
    ca_key, ca_certificate = load_authority(directory)
    key_path, chain_path = host_files(directory, name)
    if key_path.exists() and not force:
        raise SiteError(f'{key_path} exists: a key is never overwritten without --force')
    key = _new_key(bits)
    now = _now()
    end = min(now + datetime.timedelta(days=days), ca_certificate.not_valid_after_utc)
    certificate = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)]))
        .issuer_name(ca_certificate.subject).public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(end)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.KeyUsage(digital_signature=True, content_commitment=False,
                                     key_encipherment=True, data_encipherment=False,
                                     key_agreement=False, key_cert_sign=False, crl_sign=False,
                                     encipher_only=False, decipher_only=False), critical=True)
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH,
                                              ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
        .add_extension(x509.SubjectAlternativeName(
            [x509.DNSName(name), x509.IPAddress(ipaddress.IPv4Address(ip))]), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(
            ca_key.public_key()), critical=False)
        .sign(ca_key, hashes.SHA256()))
    _write_key(key_path, key, force)
    chain_path.write_bytes(certificate.public_bytes(serialization.Encoding.PEM) +
                           ca_certificate.public_bytes(serialization.Encoding.PEM))
    return certificate
