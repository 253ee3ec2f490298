# logram as a user C module of a make-built port (the unix port: the host build).
LOGRAM_DIR := $(USERMOD_DIR)
SRC_USERMOD_C += $(LOGRAM_DIR)/modlogram.c
