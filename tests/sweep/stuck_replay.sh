#!/bin/bash
# A stand-in for a replay stuck past its interrupt's grace (test_sweep's runner tests): it ignores
# SIGINT, SIGTERM and SIGHUP and sleeps; only SIGKILL ends it.
trap '' INT TERM HUP
exec sleep 60
