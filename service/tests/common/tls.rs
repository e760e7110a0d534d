//! Certificates for the zenoh TLS tests (made with `openssl`) and the configuration
//! files of docs/zenoh/ pointed at them. Shared by service/tests and the ROS 2 node's
//! zenoh test (ros2/tests/remote_daemon.rs, which includes this file by path).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

fn openssl(dir: &Path, args: &[&str]) {
    let out = Command::new("openssl")
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run openssl (install it: apt-get install openssl)");
    assert!(
        out.status.success(),
        "openssl {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A CA, a certificate for cliffd (127.0.0.1) and one per client common name.
pub fn certificates(dir: &Path, clients: &[&str]) {
    let ec = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:prime256v1",
        "-nodes",
    ];
    let mut ca = vec!["req", "-x509"];
    ca.extend(ec);
    ca.extend([
        "-keyout",
        "ca.key",
        "-out",
        "ca.pem",
        "-days",
        "2",
        "-subj",
        "/CN=cliff-test-ca",
        "-addext",
        "basicConstraints=critical,CA:TRUE",
        "-addext",
        "keyUsage=critical,keyCertSign,cRLSign",
    ]);
    openssl(dir, &ca);
    let sign = |name: &str, ext: &str| {
        std::fs::write(dir.join(format!("{name}.ext")), ext).unwrap();
        let (key, csr, pem, extf, subj) = (
            format!("{name}.key"),
            format!("{name}.csr"),
            format!("{name}.pem"),
            format!("{name}.ext"),
            format!("/CN={name}"),
        );
        let mut req = vec!["req"];
        req.extend(ec);
        req.extend(["-keyout", &key, "-out", &csr, "-subj", &subj]);
        openssl(dir, &req);
        openssl(
            dir,
            &[
                "x509",
                "-req",
                "-in",
                &csr,
                "-CA",
                "ca.pem",
                "-CAkey",
                "ca.key",
                "-CAcreateserial",
                "-out",
                &pem,
                "-days",
                "2",
                "-extfile",
                &extf,
            ],
        );
    };
    sign(
        "cliffd",
        "subjectAltName=IP:127.0.0.1,DNS:localhost\nextendedKeyUsage=serverAuth\n",
    );
    for c in clients {
        sign(c, "extendedKeyUsage=clientAuth\n");
    }
}

/// A file of docs/zenoh/ with the certificate directory (`cert_as`: whose certificate a
/// robot's file names) and the service name `service` put in.
pub fn docs_config(file: &str, dir: &Path, cert_as: &str, service: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../docs/zenoh")
        .join(file);
    let text = std::fs::read_to_string(&src).expect("docs/zenoh config");
    let text = text
        .replace(
            "/etc/cliff/robot-1",
            &format!("{}/{cert_as}", dir.display()),
        )
        .replace("/etc/cliff/", &format!("{}/", dir.display()))
        .replace("\"cliff/predict\"", &format!("{service:?}"))
        .replace("\"cliff/predict/", &format!("\"{service}/"));
    let out = dir.join(format!("{cert_as}-{file}"));
    std::fs::write(&out, text).unwrap();
    out
}
