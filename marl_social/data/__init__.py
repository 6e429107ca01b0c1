"""Learning data: demonstration and decision files (formats, validation) and the INTERACTION
dataset loader.
"""
