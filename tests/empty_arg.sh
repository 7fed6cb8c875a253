#!/bin/sh
# Runs a command with every argument "{}" replaced by an empty one: a CMake list (tests/cli.cmake's
# CMD) cannot hold an empty element.
#   sh tests/empty_arg.sh COMMAND ARG... ({} for an empty argument)
for a in "$@"; do
  shift
  if [ "$a" = "{}" ]; then set -- "$@" ""; else set -- "$@" "$a"; fi
done
exec "$@"
