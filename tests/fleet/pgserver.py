"""A real PostgreSQL for the fleet tests: initdb and pg_ctl in a temporary directory, run as the
`postgres` user, on a free loopback port, TLS on with a CA and a server certificate this helper
makes with openssl. Stations connect over TLS only (hostssl, scram-sha-256); the administrator
over the server's Unix socket."""
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import time
import unittest

PG_BIN = "/usr/lib/postgresql/15/bin"


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def available():
    """None when a server can be started here, else why not."""
    if os.geteuid() != 0:
        return "the test server runs as the postgres user, which needs root to switch to"
    if not os.path.exists(os.path.join(PG_BIN, "pg_ctl")):
        return f"PostgreSQL 15 is not installed ({PG_BIN}/pg_ctl missing; apt-get install postgresql-15)"
    try:
        pwd.getpwnam("postgres")
    except KeyError:
        return "no postgres user (the postgresql-15 package creates it)"
    if shutil.which("openssl") is None:
        return "openssl is not installed"
    return None


class PgServer:
    def __init__(self):
        self.tmp = tempfile.mkdtemp(prefix="brakefit-pg-")
        os.chmod(self.tmp, 0o755)
        self.data = os.path.join(self.tmp, "data")
        self.sock = os.path.join(self.tmp, "sock")
        os.mkdir(self.sock)
        self.port = free_port()
        self.pw = pwd.getpwnam("postgres")
        os.chown(self.sock, self.pw.pw_uid, self.pw.pw_gid)
        self.log = os.path.join(self.sock, "server.log")
        os.mkdir(self.data, 0o700)
        os.chown(self.data, self.pw.pw_uid, self.pw.pw_gid)
        self._certificates()
        self._as_pg([os.path.join(PG_BIN, "initdb"), "-D", self.data, "-U", "postgres",
                     "--auth-local=trust", "--auth-host=reject", "-E", "UTF8"])
        with open(os.path.join(self.data, "postgresql.conf"), "a") as f:
            f.write(f"port = {self.port}\nlisten_addresses = '127.0.0.1'\n"
                    f"unix_socket_directories = '{self.sock}'\nssl = on\n"
                    f"ssl_cert_file = '{self.tmp}/server.crt'\nssl_key_file = '{self.tmp}/server.key'\n"
                    "password_encryption = 'scram-sha-256'\nfsync = off\nmax_connections = 200\n"
                    "log_min_messages = warning\n")
        with open(os.path.join(self.data, "pg_hba.conf"), "w") as f:
            f.write("local all postgres trust\n"
                    "hostssl all all 127.0.0.1/32 scram-sha-256\n"
                    "host all all 127.0.0.1/32 reject\n")
        self.start()
        self.psql("CREATE DATABASE brakefit", db="postgres")

    def _as_pg(self, cmd, check=True):
        return subprocess.run(["runuser", "-u", "postgres", "--"] + cmd, capture_output=True,
                              text=True, check=check, timeout=120)

    def _certificates(self):
        t = self.tmp

        def ossl(*args):
            subprocess.run(["openssl", *args], check=True, capture_output=True, cwd=t)

        ossl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj",
             "/CN=brakefit test CA", "-keyout", "ca.key", "-out", "ca.crt")
        ossl("req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=localhost", "-keyout",
             "server.key", "-out", "server.csr")
        with open(os.path.join(t, "san.ext"), "w") as f:
            f.write("subjectAltName = DNS:localhost\n")
        ossl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key",
             "-CAcreateserial", "-days", "2", "-extfile", "san.ext", "-out", "server.crt")
        # A second CA the server's certificate is not signed by (verify-full must refuse it).
        ossl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj",
             "/CN=another CA", "-keyout", "other.key", "-out", "other.crt")
        for name in ("server.key", "server.crt"):
            os.chown(os.path.join(t, name), self.pw.pw_uid, self.pw.pw_gid)
        os.chmod(os.path.join(t, "server.key"), 0o600)
        self.ca = os.path.join(t, "ca.crt")
        self.other_ca = os.path.join(t, "other.crt")

    def start(self):
        # After a kill -9 the old backends notice their postmaster's death only at their next
        # check, and hold its shared memory until then: a start is refused until they are gone.
        for attempt in range(40):
            r = self._as_pg([os.path.join(PG_BIN, "pg_ctl"), "-D", self.data, "-l", self.log, "-w",
                             "-t", "60", "start"], check=False)
            if r.returncode == 0:
                return
            time.sleep(0.5)
        raise RuntimeError(f"PostgreSQL did not start: {r.stderr}{open(self.log).read()[-2000:]}")

    def stop(self, mode="fast"):
        self._as_pg([os.path.join(PG_BIN, "pg_ctl"), "-D", self.data, "-m", mode, "-w", "stop"],
                    check=False)

    def kill9(self):
        with open(os.path.join(self.data, "postmaster.pid")) as f:
            pid = int(f.readline())
        os.kill(pid, 9)
        # The children go with it on their next check; wait for the port to free.
        for _ in range(100):
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                time.sleep(0.1)
            except OSError:
                break
        # A postmaster killed with -9 leaves its pid file; pg_ctl start handles it.
        time.sleep(0.5)

    def psql(self, sql, db="brakefit", user="postgres"):
        r = self._as_pg(["psql", "-X", "-q", "-A", "-t", "-v", "ON_ERROR_STOP=1", "-h", self.sock,
                         "-p", str(self.port), "-U", user, "-d", db, "-c", sql], check=False)
        if r.returncode != 0:
            raise RuntimeError(f"psql {sql!r}: {r.stderr}")
        return r.stdout.strip()

    def admin_url(self, db="brakefit"):
        return f"postgresql:///{db}?host={self.sock}&port={self.port}&user=postgres"

    def station_url(self, role, ca=None, host="localhost", db="brakefit"):
        return f"postgresql://{role}@{host}:{self.port}/{db}?sslrootcert={ca or self.ca}"

    def close(self):
        self.stop("immediate")
        shutil.rmtree(self.tmp, ignore_errors=True)


def skip_unless_available():
    why = available()
    if why:
        raise unittest.SkipTest(f"fleet tests skipped: {why}")
