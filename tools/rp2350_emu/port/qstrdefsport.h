// qstrs specific to this port (most are collected automatically)
Q(/rom)
Q(/rom/lib)
