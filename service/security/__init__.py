"""Who may talk to whom: mutual TLS and zenoh access control for clusters (cluster.py), user accounts
(accounts.py), and the certificates a test or a first start makes (certificates.py). Zenoh's own
authentication and access control do the work; this package only writes their configuration."""
