# Command-line tests: run `ebh` and check exit codes and messages. Each add_test here names what
# a user would type.
set(EBH_BIN $<TARGET_FILE:ebh>)
add_test(NAME cli.version COMMAND ${EBH_BIN} --version)
set_tests_properties(cli.version PROPERTIES PASS_REGULAR_EXPRESSION "ebh [0-9]+\\.[0-9]+" LABELS cli)
