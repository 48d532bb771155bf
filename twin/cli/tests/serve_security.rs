//! `twin serve --security` against an OPC UA stack the twin did not write (Python asyncua, from
//! `scripts/test-tools`), and the machine link's client side against `twin serve`: a client's
//! certificate is refused until it is moved from the server's `rejected/` into `trusted/` (with
//! one line on stderr naming it), then a SignAndEncrypt session with the right password drives
//! the crank in lockstep; a wrong password and an anonymous session are refused; a host beyond
//! loopback needs security and a user. Every test has its own scratch folder and PKI folder.

mod common;

use common::{finished, free_port, parts, scratch, tools_python};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};
use twin_cli::machine_link::link::Security;
use twin_cli::machine_link::{LinkEvent, LinkOptions, MachineLink, MappedNode};

const USER: &str = "operator";
const PASSWORD: &str = "crank-and-ram 42";
/// How long a server may take to end after SIGTERM or after its run.
const END: Duration = Duration::from_secs(30);

/// `twin serve whitworth-crank-pi --lockstep` secured with SignAndEncrypt, the user and the
/// password file in `dir`, the PKI folder `dir/pki`; `extra` appended.
fn serve(dir: &Path, url: &str, extra: &[&str]) -> Child {
    std::fs::write(dir.join("password"), format!("{PASSWORD}\n")).unwrap();
    Command::new(env!("CARGO_BIN_EXE_twin"))
        .args([
            "serve",
            "whitworth-crank-pi",
            "--lockstep",
            "--duration",
            "0.05",
        ])
        .args(["--opcua", url, "--security", "sign-encrypt", "--pki", "pki"])
        .args([
            "--user",
            USER,
            "--password-file",
            "password",
            "--out",
            "run.rrd",
        ])
        .args(extra)
        .current_dir(dir)
        .env_remove("TWIN_OPCUA_PASSWORD")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("twin serve starts")
}

/// The Python client's JSON: `client.py URL SecurityMode CERT_DIR USER PASSWORD ACTION`.
fn client(
    url: &str,
    mode: &str,
    dir: &Path,
    user: &str,
    password: &str,
    action: &str,
) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/serve_security/client.py");
    let output = finished(
        Command::new(tools_python())
            .arg(script)
            .args([url, mode])
            .arg(dir.join("client"))
            .args([user, password, action])
            .current_dir(dir),
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "client: {stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("client said {stdout}: {e}"))
}

/// The server's output once it has ended (after SIGTERM if `terminate`); killed and the test
/// failed if it does not end within [`END`].
fn ended(mut server: Child, terminate: bool) -> Output {
    if terminate {
        let sent = Command::new("kill")
            .args(["-TERM", &server.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
    }
    let start = Instant::now();
    while server.try_wait().unwrap().is_none() {
        if start.elapsed() > END {
            server.kill().ok();
            let output = server.wait_with_output().unwrap();
            panic!(
                "twin serve still running after {END:?}: {}",
                String::from_utf8_lossy(&output.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    server.wait_with_output().unwrap()
}

/// The files in a folder.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    found.sort();
    found
}

/// Moves the one certificate in `pki/rejected/` into `pki/trusted/` (as the guide says).
fn trust_rejected(pki: &Path) -> PathBuf {
    let rejected = files(&pki.join("rejected"));
    assert_eq!(rejected.len(), 1, "{rejected:?}");
    let trusted = pki.join("trusted").join(rejected[0].file_name().unwrap());
    std::fs::rename(&rejected[0], &trusted).unwrap();
    trusted
}

/// A secured server whose client certificate (made by the first, refused, attempt) has been
/// moved into its trusted folder.
fn trusted_server(dir: &Path, url: &str, connect_url: &str) -> Child {
    let server = serve(dir, url, &[]);
    let seen = client(
        connect_url,
        "SignAndEncrypt",
        dir,
        USER,
        PASSWORD,
        "connect",
    );
    assert!(seen["refused"].as_str().is_some(), "{seen}");
    trust_rejected(&dir.join("pki"));
    server
}

/// A trusted client that gives the right password reads, writes and advances the run to its
/// end over SignAndEncrypt.
fn drives_the_run(dir: &Path, url: &str, server: Child) {
    let seen = client(url, "SignAndEncrypt", dir, USER, PASSWORD, "lockstep");
    let served = ended(server, false);
    let stderr = String::from_utf8_lossy(&served.stderr);
    assert!(seen.get("refused").is_none(), "{seen}\nserver: {stderr}");
    assert!(served.status.success(), "server: {stderr}");
    assert_eq!(seen["position_before"], 0.0, "{seen}");
    assert_eq!(seen["advanced_to"], 10, "{seen}");
    assert_eq!(seen["period_after"], 10, "{seen}");
    assert!(seen["position_after"].as_f64().unwrap() > 0.0, "{seen}");
    assert_eq!(seen["advanced_to_end"], 50, "{seen}");
    assert!(dir.join("run.rrd").is_file());
    assert!(parts(dir).is_empty(), "{:?}", parts(dir));
}

#[test]
fn a_trusted_client_with_its_password_drives_the_crank_sign_and_encrypt() {
    let dir = scratch("serve-security", "trusted");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let server = trusted_server(&dir, &url, &url);
    drives_the_run(&dir, &url, server);
    let pki = dir.join("pki");
    assert!(pki.join("own/cert.der").is_file() && pki.join("private/private.pem").is_file());
    assert!(files(&pki.join("rejected")).is_empty());
}

#[test]
fn an_untrusted_client_certificate_is_refused_in_one_line_naming_it() {
    let dir = scratch("serve-security", "untrusted");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let server = serve(&dir, &url, &[]);
    let seen = client(&url, "SignAndEncrypt", &dir, USER, PASSWORD, "lockstep");
    let served = ended(server, true);
    let stderr = String::from_utf8_lossy(&served.stderr);
    assert!(
        seen["refused"]
            .as_str()
            .is_some_and(|r| r.contains("BadCertificateUntrusted")),
        "{seen}\nserver: {stderr}"
    );
    let pki = dir.join("pki").canonicalize().unwrap();
    let rejected = files(&pki.join("rejected"));
    assert_eq!(rejected.len(), 1, "{rejected:?}");
    assert!(files(&pki.join("trusted")).is_empty());
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("twin serve: refused"))
        .collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    let expected = format!(
        "twin serve: refused a client: its certificate {} is not trusted; to trust it, move it \
         into {}/",
        rejected[0].display(),
        pki.join("trusted").display()
    );
    assert_eq!(lines[0], expected, "{stderr}");
    // Interrupted while waiting for a client: the run's files are whole, none half-written.
    assert!(dir.join("run.rrd").is_file(), "{stderr}");
    assert!(parts(&dir).is_empty(), "{:?}", parts(&dir));
}

#[test]
fn a_wrong_password_and_an_anonymous_session_are_refused() {
    let dir = scratch("serve-security", "password");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let server = trusted_server(&dir, &url, &url);
    let wrong = client(
        &url,
        "SignAndEncrypt",
        &dir,
        USER,
        "not the password",
        "connect",
    );
    let anonymous = client(&url, "SignAndEncrypt", &dir, "-", "-", "connect");
    let unsecured = client(&url, "None", &dir, USER, PASSWORD, "connect");
    let served = ended(server, true);
    let stderr = String::from_utf8_lossy(&served.stderr);
    for seen in [&wrong, &anonymous, &unsecured] {
        assert!(
            seen["refused"].as_str().is_some(),
            "{seen}\nserver: {stderr}"
        );
    }
    assert!(
        stderr.contains(&format!(
            "twin serve: refused a session of user \"{USER}\": wrong user name or password"
        )),
        "{stderr}"
    );
    assert!(!stderr.contains(PASSWORD) && !stderr.contains("not the password"));
}

#[test]
fn beyond_loopback_needs_security_and_a_user() {
    let dir = scratch("serve-security", "beyond");
    for extra in [&[][..], &["--security", "sign-encrypt"][..]] {
        let output = finished(
            Command::new(env!("CARGO_BIN_EXE_twin"))
                .args([
                    "serve",
                    "whitworth-crank-pi",
                    "--opcua",
                    "opc.tcp://0.0.0.0:4840",
                ])
                .args(extra)
                .args(["--pki", "pki"].iter().filter(|_| !extra.is_empty()))
                .current_dir(&dir),
        );
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert_eq!(common::error_lines(&stderr), 1, "{stderr}");
        assert!(
            stderr.contains("0.0.0.0 is not a loopback address")
                && stderr.contains("needs --security sign-encrypt (or sign) and --user NAME"),
            "{stderr}"
        );
    }
    assert!(
        !dir.join("pki").exists(),
        "a refused command made its PKI folder"
    );
    // With SignAndEncrypt and a user, on every address (the client comes over loopback); the
    // password from the environment this time.
    let port = free_port();
    let any = format!("opc.tcp://0.0.0.0:{port}");
    let local = format!("opc.tcp://127.0.0.1:{port}");
    let server = {
        std::fs::write(dir.join("password"), format!("{PASSWORD}\n")).unwrap();
        Command::new(env!("CARGO_BIN_EXE_twin"))
            .args([
                "serve",
                "whitworth-crank-pi",
                "--lockstep",
                "--duration",
                "0.05",
            ])
            .args([
                "--opcua",
                &any,
                "--security",
                "sign-encrypt",
                "--pki",
                "pki",
            ])
            .args(["--user", USER, "--out", "run.rrd"])
            .env("TWIN_OPCUA_PASSWORD", PASSWORD)
            .current_dir(&dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("twin serve starts")
    };
    let seen = client(&local, "SignAndEncrypt", &dir, USER, PASSWORD, "connect");
    assert!(seen["refused"].as_str().is_some(), "{seen}");
    trust_rejected(&dir.join("pki"));
    drives_the_run(&dir, &local, server);
}

#[test]
fn the_machine_link_names_the_certificate_to_trust_on_each_side() {
    let dir = scratch("serve-security", "link");
    let url = format!("opc.tcp://127.0.0.1:{}", free_port());
    let server = serve(&dir, &url, &[]);
    let link_pki = dir.join("link-pki");
    let options = LinkOptions {
        connect_timeout: Duration::from_secs(20),
        security: Security::SignAndEncrypt,
        pki: Some(link_pki.clone()),
        user: Some((USER.into(), PASSWORD.into())),
        ..LinkOptions::default()
    };
    let nodes = [MappedNode {
        column: "crank.position".into(),
        node: "nsu=urn:twin:whitworth;s=crank.position".into(),
        unit: "rad".into(),
    }];
    // The server does not trust the link's certificate yet.
    let message = MachineLink::connect(&url, &nodes, options.clone())
        .err()
        .expect("refused")
        .to_string();
    let link_pki = link_pki.canonicalize().unwrap();
    let own = link_pki.join("own/cert.der");
    assert!(
        message.contains(&format!(
            "does not trust the twin's certificate {}",
            own.display()
        )) && message.contains("trust it on the machine's server")
            && !message.contains('\n'),
        "{message}"
    );
    trust_rejected(&dir.join("pki"));
    // The link does not trust the server's certificate yet.
    let message = MachineLink::connect(&url, &nodes, options.clone())
        .err()
        .expect("refused")
        .to_string();
    let rejected = files(&link_pki.join("rejected"));
    assert_eq!(rejected.len(), 1, "{message}");
    assert!(
        message.contains(&format!(
            "its certificate {} is not trusted by the twin",
            rejected[0].display()
        )) && message.contains(&format!(
            "moving it into {}/",
            link_pki.join("trusted").display()
        )),
        "{message}"
    );
    trust_rejected(&link_pki);
    let mut link = MachineLink::connect(&url, &nodes, options).expect("connects");
    let event = link.recv(Duration::from_secs(20));
    assert!(
        matches!(event, Some(LinkEvent::Sample { node: 0, value, .. }) if value == 0.0),
        "{event:?}"
    );
    link.close();
    let served = ended(server, true);
    let stderr = String::from_utf8_lossy(&served.stderr);
    assert_eq!(
        stderr
            .lines()
            .filter(|l| l.starts_with("twin serve: refused"))
            .count(),
        1,
        "{stderr}"
    );
}
