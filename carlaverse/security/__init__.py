"""Identity and access control for multi-site sessions (docs/architecture.md §2, §12).

- `certs`: a private test CA and per-site router / per-node certificates (PEM files).
- `roster`: the session roster, who may join from where with which credential.
- `acl`: the Zenoh `access_control` block each site router enforces for its own nodes.
- `zenoh_entries`: raw Zenoh config entries (TLS, user/password, ACL) for `FabricSettings.zenoh`.
- `router_config`: `router_settings_for_site(config, site)`, what `carlaverse router` runs.

Errors (all `ValueError`s, so a CLI reports them as bad input):

    ValueError
     ├── carlaverse.config.ConfigError   a roster or file that cannot be read or validated
     │    └── RosterError                the roster is well-formed YAML but inconsistent
     └── CertificateError                a certificate or key file is missing or unusable
"""
