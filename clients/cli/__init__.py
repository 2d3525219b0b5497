"""The `acphys` command line's machinery (connecting, endpoints, values, failures said in one line) and
its plain commands (inspect, load-region, the queries, path). The entry is clients/__main__.py."""
